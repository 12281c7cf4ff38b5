"""The exact part-pair solver of the learned path (``part_pair_contacts``): given the touching
part pairs, or more, it answers what the oracle answers, bit for bit; it refuses candidates
that are not sorted by pose."""
import numpy as np
import pytest

from impactnet.models.compound import container, spreader
from impactnet.models.compound.oracle import compound_contacts, part_pair_contacts

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _landing_poses(n: int, seed: int):
    """A spreader set down on a 40 ft container at detail 2, shifted and tilted about random
    axes: the heads strike the apertures' rings and sides."""
    rng = np.random.default_rng(seed)
    position = np.c_[rng.uniform(-0.02, 0.02, (n, 2)), np.full(n, 2.591 / 2 + 0.4 + 0.004)]
    position[:, 2] -= rng.uniform(0.0, 0.006, n)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    half = 0.5 * rng.uniform(0, 0.01, n)  # tilt angle / 2, radians
    return position, np.c_[np.cos(half), np.sin(half)[:, None] * axis]


def _same(got, want):
    """The same part contacts per pose (within a pose, in any order)."""
    np.testing.assert_array_equal(got.offsets, want.offsets)
    mine = np.lexsort((got.part_b, got.part_a, got.pose))
    theirs = np.lexsort((want.part_b, want.part_a, want.pose))
    np.testing.assert_array_equal(got.part_a[mine], want.part_a[theirs])
    np.testing.assert_array_equal(got.part_b[mine], want.part_b[theirs])
    for name, value in want.contacts.arrays().items():
        np.testing.assert_array_equal(getattr(got.contacts, name)[mine], value[theirs],
                                      err_msg=name)


def test_the_touching_part_pairs_alone_give_the_oracles_answer_bit_for_bit():
    parts_a, parts_b = container("40ft", detail=2), spreader("40ft", sides=16)
    position, quaternion = _landing_poses(64, 1)
    want = compound_contacts(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion)
    assert want.offsets[-1] > 64  # the poses touch
    got = part_pair_contacts(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion,
                             want.pose, want.part_a, want.part_b)
    _same(got, want)


def test_extra_candidates_that_do_not_touch_are_dropped():
    parts_a, parts_b = container("40ft", detail=2), spreader("40ft", sides=16)
    position, quaternion = _landing_poses(32, 2)
    want = compound_contacts(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion)
    n = len(position)
    pose = np.repeat(np.arange(n), len(parts_a) * len(parts_b))
    part_a = np.tile(np.repeat(np.arange(len(parts_a)), len(parts_b)), n)
    part_b = np.tile(np.arange(len(parts_b)), n * len(parts_a))
    got = part_pair_contacts(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion,
                             pose, part_a, part_b)
    _same(got, want)


def test_candidates_out_of_pose_order_are_refused():
    parts = container("20ft", detail=1)
    with pytest.raises(ValueError, match="sorted by pose"):
        part_pair_contacts(parts, np.zeros(3), IDENTITY, parts, np.zeros((2, 3)),
                           np.tile(IDENTITY, (2, 1)), [1, 0], [0, 0], [0, 0])
