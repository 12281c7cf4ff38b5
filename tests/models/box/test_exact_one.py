"""One pair and a batch give the same answer, bit for bit: the one-pair entry (six vectors),
the serial kernel of small batches and the parallel kernel of large ones run the same row
function (models/box/kernels.py)."""
import numpy as np
import pytest

from impactnet.models.box.decision import single_pair
from impactnet.models.box.exact import box_box
from impactnet.models.compiled import PARALLEL_MIN_ROWS
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
def test_one_pair_equals_its_row_of_a_batch_on_every_family(seed):
    p = family_poses(per_case=60 if seed == 0 else 600, seed=seed)
    batch = box_box(*(p[k] for k in KEYS))
    assert len(batch) >= PARALLEL_MIN_ROWS  # the parallel kernel answered the batch
    for i in range(len(batch)):
        assert_rows_equal(batch, i, box_box(*(p[k][i] for k in KEYS)))


def test_one_pair_as_lists_and_small_batches_give_the_same_rows():
    p = family_poses(per_case=4, seed=1)
    batch = box_box(*(p[k] for k in KEYS))
    for i in range(0, len(batch) - 3, 3):
        assert_rows_equal(batch, i, box_box(*(p[k][i].tolist() for k in KEYS)))
        small = box_box(*(p[k][i:i + 3] for k in KEYS))  # the serial kernel
        for j in range(3):
            assert_rows_equal(batch, i + j, small.row(j))


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
