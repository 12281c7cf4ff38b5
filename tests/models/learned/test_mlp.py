"""Frozen MLPs: the compiled forward pass against the contract's formula in float64, one row
against its batch, committees against their members, the vectorised tanh against NumPy's;
tensor round trip and refused tensors."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.compiled import CHUNK_ROWS, PARALLEL_MIN_ROWS, jit
from impactnet.models.learned import kernel_mlp as km
from impactnet.models.learned import mlp as mm
from impactnet.models.learned.mlp import MLPStack

#: Agreement of the compiled forward pass with the contract's formula evaluated by NumPy in
#: float64, relative to the largest output of the row: the two differ only in the order of
#: their sums (BLAS blocks and fuses them) and in the last bit of tanh (measured worst: 2e-14
#: on 300 outputs after three 128-wide tanh layers).
FORWARD_RTOL = 1e-12
#: The kernel's tanh against NumPy's: one unit of 1.0 absolute, a few units relative.
TANH_ATOL, TANH_RTOL = 2.3e-16, 1.5e-15


def random_mlp(layers, activation="tanh", seed=0, classifier=False,
               outputs="contact-v1") -> mm.MLP:
    """An MLP with torch-like initialisation and non-trivial normalisations."""
    rng = np.random.default_rng(seed)
    spec = mm.MLPSpec(activation, tuple(layers), outputs=outputs)
    weights = [rng.uniform(-1, 1, (o, i)) / np.sqrt(i) for i, o in zip(layers[:-1], layers[1:])]
    biases = [rng.uniform(-0.1, 0.1, o) for o in layers[1:]]
    n_out = layers[-1]
    out_mean, out_scale = ((np.zeros(n_out), np.ones(n_out)) if classifier else
                           (rng.normal(size=n_out), rng.uniform(0.5, 2.0, n_out)))
    return mm.MLP(spec, weights, biases, rng.normal(size=layers[0]),
                  rng.uniform(0.2, 2.0, layers[0]), out_mean, out_scale)


def reference_forward(model: mm.MLP, x) -> np.ndarray:
    """The contract's formula, literally, in float64 (NumPy: BLAS matmuls, libm tanh)."""
    h = (np.asarray(x, np.float64) - model.in_mean_) / model.in_scale_
    for k, (w, b) in enumerate(zip(model.weights_, model.biases_)):
        h = h @ w.astype(np.float64).T + b
        if k < len(model.weights_) - 1:
            h = np.tanh(h) if model.spec.activation == "tanh" else np.maximum(h, 0.0)
    return h * model.out_scale_ + model.out_mean_


def row_relative(y, reference) -> np.ndarray:
    """|y - reference| per row, relative to the row's largest |reference| output."""
    return np.abs(y - reference).max(axis=1) / np.abs(reference).max(axis=1)


@pytest.mark.parametrize("activation", ["tanh", "relu"])
@pytest.mark.parametrize("layers", [(12, 7), (12, 24, 24, 7), (12, 64, 64, 40),
                                    (9, 128, 128, 128, 300)])
@pytest.mark.parametrize("m", [1, 3, PARALLEL_MIN_ROWS + 5])
def test_forward_matches_the_formula_in_float64(activation, layers, m):
    model = random_mlp(layers, activation)
    x = np.random.default_rng(1).normal(size=(m, layers[0])) * 2.0
    y = model.forward(x)
    assert y.dtype == np.float64 and y.shape == (m, layers[-1])
    assert row_relative(y, reference_forward(model, x)).max() <= FORWARD_RTOL


def test_a_row_alone_equals_its_row_of_a_batch_bit_for_bit():
    """One kernel for N = 1 and any batch: serial, parallel and chunked batches alike."""
    model = random_mlp((12, 32, 32, 7))
    x = np.random.default_rng(2).normal(size=(CHUNK_ROWS + 300, 12))
    batch = model.forward(x)
    for i in (0, 7, PARALLEL_MIN_ROWS + 1, CHUNK_ROWS + 299):
        np.testing.assert_array_equal(model(x[i:i + 1])[0], batch[i])
        np.testing.assert_array_equal(model.forward(x[:i + 1])[i], batch[i])


def test_tanh_is_numpys_to_the_last_units():
    grid = np.concatenate([np.linspace(-25, 25, 200_001), np.logspace(-300, 1.5, 20_000),
                           -np.logspace(-300, 1.5, 20_000), [0.0, -0.0, 0.125, 20.0, 1e300]])

    @jit
    def loop(x, out):
        for i in range(x.size):
            out[i] = km.tanh(x[i])

    got = np.empty_like(grid)
    loop(grid, got)
    expected = np.tanh(grid)
    error = np.abs(got - expected)
    assert error.max() <= TANH_ATOL
    assert (error <= TANH_RTOL * np.abs(expected)).all()
    np.testing.assert_array_equal(np.signbit(got), np.signbit(expected))


def test_tensors_round_trip():
    model = random_mlp((12, 32, 7), "relu")
    tensors = model.to_tensors("expert.a")
    assert sorted(tensors) == sorted(model.spec.shapes("expert.a"))
    assert tensors["expert.a.w0"].shape == (32, 12) and tensors["expert.a.w0"].dtype == np.float32
    back = mm.MLP.from_tensors("expert.a", {**tensors, "other.w0": np.zeros(3)},
                               model.spec.to_dict())
    x = np.random.default_rng(3).normal(size=(50, 12))
    np.testing.assert_array_equal(back(x), model(x))
    for name in tensors:
        np.testing.assert_array_equal(back.to_tensors("expert.a")[name], tensors[name])


def test_weights_are_read_only():
    model = random_mlp((12, 7))
    with pytest.raises(ValueError):
        model.weights_[0][0, 0] = 1.0
    with pytest.raises(ValueError):
        model.pack.weights[0] = 1.0


@pytest.mark.parametrize("change, message", [
    (lambda t: t.pop("m.b1"), "missing tensor 'm.b1'"),
    (lambda t: t.update({"m.w0": np.zeros((12, 8), np.float32)}), "shape"),
    (lambda t: t.update({"m.in_scale": np.zeros(12, np.float32)}), "in_scale must be > 0"),
    (lambda t: t.update({"m.w1": np.full((7, 8), np.nan, np.float32)}), "not finite"),
])
def test_bad_tensors_are_refused(change, message):
    model = random_mlp((12, 8, 7))
    tensors = model.to_tensors("m")
    change(tensors)
    with pytest.raises(mm.MLPError, match=message):
        mm.MLP.from_tensors("m", tensors, model.spec)


@pytest.mark.parametrize("entry", [
    {"activation": "gelu", "layers": [12, 7]},
    {"activation": "tanh", "layers": [12]},
    {"activation": "tanh", "layers": [12, 0, 7]},
    {"activation": "tanh", "layers": [12, 7.0]},
    {"activation": "tanh"},
    {"activation": "tanh", "layers": [12, 7], "dropout": 0.1},
])
def test_bad_specs_are_refused(entry):
    with pytest.raises(mm.MLPError):
        mm.MLPSpec.from_dict(entry)


def test_bad_inputs_are_refused():
    with pytest.raises(mm.MLPError, match=r"expected inputs \(m, 12\)"):
        random_mlp((12, 7)).forward(np.zeros((3, 11)))


@pytest.mark.parametrize("m", [1, PARALLEL_MIN_ROWS + 3])
def test_stack_equals_its_members_bit_for_bit(m):
    members = [random_mlp((12, 32, 32, 7), seed=s) for s in range(3)]
    stack = MLPStack(members)
    x = np.random.default_rng(4).normal(size=(m, 12))
    y = stack.forward(x)
    assert y.shape == (3, m, 7) and y.dtype == np.float64
    for k, member in enumerate(members):
        np.testing.assert_array_equal(y[k], member(x))


def test_stack_of_mixed_architectures_equals_its_members():
    members = [random_mlp((12, 8, 7), seed=1), random_mlp((12, 9, 9, 7), "relu", seed=2),
               random_mlp((12, 8, 7), seed=3)]
    x = np.random.default_rng(5).normal(size=(20, 12))
    y = MLPStack(members).forward(x)
    for k, member in enumerate(members):
        np.testing.assert_array_equal(y[k], member(x))
    with pytest.raises(mm.MLPError, match="share"):
        MLPStack([random_mlp((12, 8, 7)), random_mlp((12, 8, 6))])
