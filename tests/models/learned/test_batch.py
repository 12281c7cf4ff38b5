"""The learned predictors around their compiled row function: one pair alone is its row of any
batch to the last bit (every mode, both pairs, swapped, serial and parallel batches), eight
threads asking at once get the serial answers, and invalid inputs raise as the exact solver
raises them."""
from __future__ import annotations

import random
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from impactnet import models
from impactnet.models.box.exact import InvalidBoxError, prepare_inputs
from impactnet.models.compiled import PARALLEL_MIN_ROWS
from impactnet.models.geometry.rotations import InvalidRotationError
from impactnet.models.learned.bundle_loader import read_bundle
from tests.models.helpers import KEYS, labelled_rows
from tests.models.learned.learned_fixtures import PAIRS, write_test_bundle

MODES = ("single", "committee", "auto")


@pytest.fixture(scope="module")
def predictors(tmp_path_factory):
    bundle = read_bundle(write_test_bundle(tmp_path_factory.mktemp("b") / "bundle"))
    return {mode: models.load_predictor(mode, bundle) for mode in MODES}


def mixed(n: int, seed: int = 1) -> list[np.ndarray]:
    """n rows: brick/slab, the same swapped (slab/brick) and cube/cube, interleaved."""
    parts = [[labelled_rows(*PAIRS[key], n // 3 + 1, seed + k)[name] for name in KEYS]
             for k, key in enumerate(("brick/slab", "brick/slab", "cube/cube"))]
    parts[1] = parts[1][3:] + parts[1][:3]
    return [np.stack([p[c] for p in parts], axis=1).reshape(-1, p0.shape[1])[:n]
            for c, p0 in enumerate(parts[0])]


def assert_same(one, batch, i):
    """Prediction ``one`` (one row) is row ``i`` of Prediction ``batch``, bit for bit."""
    for name, value in one.contacts.arrays().items():
        np.testing.assert_array_equal(value[0], getattr(batch.contacts, name)[i], err_msg=name)
    assert one.normal_spread[0] == batch.normal_spread[i]
    assert one.point_spread[0] == batch.point_spread[i]


@pytest.mark.parametrize("mode", MODES)
def test_one_pair_is_its_row_of_any_batch_bit_for_bit(predictors, mode):
    """The one-pair entry (six vectors), a one-row batch and the rows of a parallel batch
    run the same row function: the same answer to the last bit, swapped rows included."""
    args = mixed(PARALLEL_MIN_ROWS + 40)
    predictor = predictors[mode]
    batch = predictor.predict(*args)
    serial = predictor.predict(*(a[:PARALLEL_MIN_ROWS - 1] for a in args))
    answered = set(batch.contacts.predictor)  # both links of the committee's chain show
    assert answered == ({"single"} if mode == "single" else {"exact", "committee"})
    for i in range(0, len(args[0]), 5):
        assert_same(predictor.predict(*(a[i] for a in args)), batch, i)
        assert_same(predictor.predict(*(a[i:i + 1] for a in args)), batch, i)
        if i < PARALLEL_MIN_ROWS - 1:
            assert_same(predictor.predict(*(a[i:i + 1] for a in args)), serial, i)
    assert_same(predictor.predict(*(a[3].tolist() for a in args)), batch, 3)  # lists


def test_eight_threads_at_once_get_the_serial_answers(predictors):
    """Requests of every mode (one pair, small batches, a batch over the kernel threads) from
    eight threads at once: each answer is the one the same request got alone."""
    args = mixed(PARALLEL_MIN_ROWS + 100, seed=7)
    requests = [(mode, rows) for mode in MODES for rows in
                (slice(5, 6), 17, slice(20, 40), slice(0, PARALLEL_MIN_ROWS + 100))]

    def ask(request):
        mode, rows = request
        return predictors[mode].predict(*(a[rows] for a in args))

    alone = [ask(r) for r in requests]
    work = [k for k in range(len(requests)) for _ in range(6)]
    random.Random(3).shuffle(work)
    with ThreadPoolExecutor(8) as pool:
        answers = list(pool.map(lambda k: (k, ask(requests[k])), work))
    for k, got in answers:
        for name, value in got.contacts.arrays().items():
            np.testing.assert_array_equal(value, getattr(alone[k].contacts, name),
                                          err_msg=f"{requests[k][0]} {name}")
        np.testing.assert_array_equal(got.normal_spread, alone[k].normal_spread)


def _args(**change):
    args = {"size_a": [[1.0, 0.6, 0.4]] * 2, "position_a": [[0.0, 0.0, 0.0]] * 2,
            "quaternion_a": [[1.0, 0.0, 0.0, 0.0]] * 2, "size_b": [2.0, 1.5, 0.3],
            "position_b": [[0.5, 0.2, 0.3]] * 2, "quaternion_b": [[0.0, 0.0, 0.0, 2.0]] * 2}
    args.update(change)
    return [np.array(args[k], dtype=float) for k in KEYS]


@pytest.mark.parametrize("change, error", [
    ({"position_a": [[np.nan, 0, 0], [0, 0, 0]]}, InvalidBoxError),
    ({"size_b": [0.0, 1.0, 1.0]}, InvalidBoxError),
    ({"size_a": [[1.0, 2.0, 3e7]] * 2}, InvalidBoxError),
    ({"position_b": [[0, 0, 2e9]] * 2}, InvalidBoxError),
    ({"quaternion_b": [[0.0, 0.0, 0.0, 0.0]] * 2}, InvalidRotationError),
    ({"quaternion_a": [[1.0, 0.0, 0.0]] * 2}, InvalidBoxError),
    ({"position_b": [[0.5, 0.2, 1.9]] * 3}, InvalidBoxError),
])
def test_invalid_inputs_raise_as_the_exact_solver(predictors, change, error):
    args = _args(**change)
    with pytest.raises(error) as expected:
        prepare_inputs(*args)
    for predictor in predictors.values():
        with pytest.raises(error) as got:
            predictor(*args)
        assert str(got.value) == str(expected.value)
        if all(a.ndim == 1 or len(a) == 2 for a in args):  # the first pair, as six vectors
            with pytest.raises(error):
                predictor(*(a[0] if a.ndim == 2 else a for a in args))
