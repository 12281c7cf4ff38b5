"""The N = 1 fast path (plain Python) and the vectorised path give the same answer, bit for
bit (the N = 1 path sums in the batch path's order)."""
import numpy as np
import pytest

from impactnet.models.box.exact import box_box, box_box_batch, prepare_inputs
from impactnet.models.box.exact_one import box_box_one, single_pair
from impactnet.models.geometry.poses import ORIENTATIONS, SIZE_FAMILIES, first_contact_poses
from tests.models.helpers import KEYS


def family_poses(per_case, seed):
    chunks = []
    for f, family in enumerate(sorted(SIZE_FAMILIES)):
        for o, orientation in enumerate(ORIENTATIONS):
            chunks.append(first_contact_poses(per_case, *SIZE_FAMILIES[family],
                                              rng=seed + 10 * f + o, separated_share=0.1,
                                              orientation=orientation, world_offset=30.0))
    return {k: np.concatenate([c[k] for c in chunks]) for k in KEYS}


def assert_rows_equal(batch, i, one):
    for name, value in one.arrays().items():
        np.testing.assert_array_equal(value[0], getattr(batch, name)[i],
                                      err_msg=f"{name} row {i}")


@pytest.mark.parametrize("seed", [0, pytest.param(100, marks=pytest.mark.slow)])
def test_scalar_path_equals_batch_path_on_every_family(seed):
    p = family_poses(per_case=60 if seed == 0 else 600, seed=seed)
    inputs = prepare_inputs(*(p[k] for k in KEYS))
    batch = box_box_batch(*inputs)
    for i in range(len(batch)):
        assert_rows_equal(batch, i, box_box_one(*(r[i].tolist() for r in inputs)))


def test_single_pair_accepts_lists_arrays_and_one_row_batches():
    args = ([1, 2, 3], [0, 0, 0], [2, 0, 0, 0], [1, 1, 1], [0.5, 0.5, 1.9], [1, 0, 0, 0])
    as_rows = [np.atleast_2d(np.asarray(a, float)) for a in args]
    assert single_pair(*args) == single_pair(*as_rows)
    assert single_pair(*args)[2] == [1.0, 0.0, 0.0, 0.0]  # normalised


@pytest.mark.parametrize("bad", [
    {0: [0, 1, 1]}, {1: [np.nan, 0, 0]}, {2: [0, 0, 0, 0]}, {3: [1, 1]},
])
def test_single_pair_declines_invalid_input_so_the_batch_path_raises(bad):
    args = [[1, 2, 3], [0, 0, 0], [1, 0, 0, 0], [1, 1, 1], [0.5, 0.5, 1.9], [1, 0, 0, 0]]
    for index, value in bad.items():
        args[index] = value
    assert single_pair(*args) is None
    with pytest.raises(ValueError):
        box_box(*args)
