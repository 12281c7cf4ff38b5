"""Frozen MLPs: the folded, chunked forward pass against the plain formula; tensor round trip."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.learned import mlp as mm
from impactnet.models.learned.mlp import MLPStack

#: Agreement of the float32 forward pass with the float64 formula, relative to the output
#: magnitude: a few float32 ulps per layer of rounding (folding and summation order).
FORWARD_RTOL = 2e-5


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
    """The contract's formula, literally, in float64."""
    h = (np.asarray(x, np.float64) - model.in_mean_) / model.in_scale_
    for k, (w, b) in enumerate(zip(model.weights_, model.biases_)):
        h = h @ w.astype(np.float64).T + b
        if k < len(model.weights_) - 1:
            h = np.tanh(h) if model.spec.activation == "tanh" else np.maximum(h, 0.0)
    return h * model.out_scale_ + model.out_mean_


@pytest.mark.parametrize("activation", ["tanh", "relu"])
@pytest.mark.parametrize("layers", [(12, 7), (12, 32, 32, 7), (12, 64, 64, 40)])
@pytest.mark.parametrize("m", [1, 3, mm.FORWARD_CHUNK + 5])
def test_forward_matches_the_plain_formula(activation, layers, m):
    model = random_mlp(layers, activation)
    x = np.random.default_rng(1).normal(size=(m, layers[0])).astype(np.float32)
    y = model.forward(x)
    assert y.dtype == np.float32 and y.shape == (m, layers[-1])
    ref = reference_forward(model, x)
    np.testing.assert_allclose(y, ref, rtol=FORWARD_RTOL, atol=FORWARD_RTOL * np.abs(ref).max())


def test_forward_writes_into_out_and_rows_are_independent():
    model = random_mlp((12, 16, 7))
    x = np.random.default_rng(2).normal(size=(10, 12)).astype(np.float32)
    out = np.empty((10, 7), np.float32)
    assert model.forward(x, out=out) is out
    np.testing.assert_allclose(model(x[4:5]), out[4:5], rtol=1e-6, atol=1e-6)


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


@pytest.mark.parametrize("m", [1, mm.FORWARD_CHUNK + 3])
def test_stack_equals_its_members(m):
    members = [random_mlp((12, 32, 32, 7), seed=s) for s in range(3)]
    stack = MLPStack(members)
    x = np.random.default_rng(4).normal(size=(m, 12)).astype(np.float32)
    y = stack.forward(x)
    assert y.shape == (3, m, 7) and y.dtype == np.float32
    for k, member in enumerate(members):
        np.testing.assert_allclose(y[k], member(x), rtol=1e-5, atol=1e-5)


def test_stack_of_mixed_architectures_equals_its_members():
    members = [random_mlp((12, 8, 7), seed=1), random_mlp((12, 9, 9, 7), "relu", seed=2),
               random_mlp((12, 8, 7), seed=3)]
    x = np.random.default_rng(5).normal(size=(20, 12))
    y = MLPStack(members).forward(x)
    for k, member in enumerate(members):
        np.testing.assert_allclose(y[k], member(x), rtol=1e-5, atol=1e-5)
    with pytest.raises(mm.MLPError, match="share"):
        MLPStack([random_mlp((12, 8, 7)), random_mlp((12, 8, 6))])


@pytest.mark.parametrize("activation", ["tanh", "relu"])
def test_one_row_paths_equal_the_batch(activation):
    model = random_mlp((12, 16, 16, 7), activation)
    members = [random_mlp((12, 8, 8, 7), activation, seed=s) for s in range(3)]
    x = np.random.default_rng(6).normal(size=(4, 12)).astype(np.float32)
    stack = MLPStack(members)
    for row in x:
        np.testing.assert_allclose(model.forward_one(row), model(row[None])[0], rtol=1e-5,
                                   atol=1e-6)
        np.testing.assert_allclose(stack.forward_one(row), stack.forward(row[None])[:, 0],
                                   rtol=1e-5, atol=1e-6)
    mixed = MLPStack([random_mlp((12, 8, 7)), random_mlp((12, 8, 8, 7), seed=1)])
    np.testing.assert_allclose(mixed.forward_one(x[0]), mixed.forward(x[:1])[:, 0],
                               rtol=1e-5, atol=1e-6)
