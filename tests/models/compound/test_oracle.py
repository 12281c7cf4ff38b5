"""The compound oracle on box parts: analytic stacking, the ragged layout, invariants."""
import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.oracle import compound_contacts, compound_touching
from impactnet.models.geometry.rotations import (
    quaternion_to_matrix,
    random_quaternions,
)

FORTY = cb.container("40ft")
HEIGHT = cb.CONTAINERS["40ft"][2]
IDENTITY = [1.0, 0.0, 0.0, 0.0]
#: Agreement (m) of the same contact computed in two frames: rounding of ~10 m coordinates.
FRAME_TOL_M = 1e-9


def _names(parts, index):
    return [parts[k].name for k in index]


def _stack(offset_xy=(0.0, 0.0), push=1e-3, n=1):
    """B on A, its bottom castings ``push`` into A's top castings."""
    position_b = np.tile([*offset_xy, HEIGHT - push], (n, 1))
    return compound_contacts(FORTY, np.zeros((n, 3)), np.tile(IDENTITY, (n, 1)), FORTY,
                             position_b, np.tile(IDENTITY, (n, 1)))


def test_aligned_stacking_touches_on_four_castings_at_the_centres_of_their_overlaps():
    found = _stack()
    assert len(found.pose) == 4
    assert sorted(_names(FORTY, found.part_a)) == sorted(
        p.name for p in FORTY if p.name.startswith("casting_top"))
    assert sorted(_names(FORTY, found.part_b)) == sorted(
        p.name for p in FORTY if p.name.startswith("casting_bottom"))
    c = found.contacts
    np.testing.assert_allclose(c.normal, np.tile([0, 0, 1.0], (4, 1)), atol=1e-15)
    np.testing.assert_allclose(c.depth, 1e-3, rtol=1e-9)
    centres = np.array([FORTY[k].centre for k in found.part_a])
    np.testing.assert_allclose(c.point[:, :2], centres[:, :2], atol=1e-12)
    np.testing.assert_allclose(c.point[:, 2], HEIGHT / 2 - 0.5e-3, atol=1e-12)


def test_offset_stacking_puts_each_point_at_the_centre_of_the_castings_overlap():
    dx, dy = 0.05, -0.03
    c = _stack((dx, dy)).contacts
    parts = np.array([FORTY[k].centre for k in _stack((dx, dy)).part_a])
    np.testing.assert_allclose(c.point[:, 0], parts[:, 0] + dx / 2, atol=1e-12)
    np.testing.assert_allclose(c.point[:, 1], parts[:, 1] + dy / 2, atol=1e-12)


def test_lifted_container_touches_nothing_and_offsets_delimit_poses():
    pushes = np.array([1e-3, -1e-3, 2e-3])
    position_b = np.stack([np.zeros(3), np.zeros(3), np.zeros(3)]) + \
        np.c_[np.zeros((3, 2)), HEIGHT - pushes]
    found = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, position_b,
                              np.tile(IDENTITY, (3, 1)))
    np.testing.assert_array_equal(found.offsets, [0, 4, 4, 8])
    assert (found.pose[found.of_pose(2)] == 2).all()


def test_swapping_the_bodies_swaps_the_parts_and_flips_the_normals():
    rng = np.random.default_rng(5)
    q_b = np.c_[np.ones(50), rng.normal(scale=1e-3, size=(50, 3))]  # tilted by ~2 mrad
    q_b /= np.linalg.norm(q_b, axis=1, keepdims=True)
    position_b = np.c_[rng.uniform(-0.2, 0.2, (50, 2)), HEIGHT - rng.uniform(0, 3e-3, 50)]
    ab = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, position_b, q_b)
    ba = compound_contacts(FORTY, position_b, q_b, FORTY, np.zeros(3), IDENTITY)
    np.testing.assert_array_equal(ab.offsets, ba.offsets)
    key_ab = sorted(zip(ab.pose, ab.part_a, ab.part_b))
    key_ba = sorted(zip(ba.pose, ba.part_b, ba.part_a))
    assert key_ab == key_ba
    order_ab = np.lexsort((ab.part_b, ab.part_a, ab.pose))
    order_ba = np.lexsort((ba.part_a, ba.part_b, ba.pose))
    np.testing.assert_allclose(ab.contacts.normal[order_ab], -ba.contacts.normal[order_ba],
                               atol=1e-9)
    np.testing.assert_allclose(ab.contacts.depth[order_ab], ba.contacts.depth[order_ba],
                               atol=FRAME_TOL_M)


def test_rigid_motion_far_from_the_origin_moves_the_contacts_with_the_bodies():
    rng = np.random.default_rng(6)
    q = random_quaternions(1, rng)[0]
    rot = quaternion_to_matrix(q)[0]
    shift = np.array([3e3, -2e3, 40.0])
    base = _stack((0.02, 0.01), n=1)
    moved = compound_contacts(FORTY, shift, q, FORTY,
                              shift + rot @ np.array([0.02, 0.01, HEIGHT - 1e-3]), q)
    np.testing.assert_array_equal(np.sort(base.part_a), np.sort(moved.part_a))
    order_base, order_moved = np.argsort(base.part_a), np.argsort(moved.part_a)
    expected = base.contacts.point[order_base] @ rot.T + shift
    np.testing.assert_allclose(moved.contacts.point[order_moved], expected, atol=1e-8)


def test_one_pose_equals_its_row_of_a_batch():
    rng = np.random.default_rng(7)
    position_b = np.c_[rng.uniform(-0.1, 0.1, (20, 2)), HEIGHT - rng.uniform(0, 2e-3, 20)]
    batch = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, position_b, IDENTITY)
    for k in (0, 7, 19):
        one = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, position_b[k], IDENTITY)
        rows = batch.of_pose(k)
        np.testing.assert_array_equal(one.part_a, batch.part_a[rows])
        np.testing.assert_array_equal(one.contacts.point, batch.contacts.point[rows])


def test_blocks_of_poses_give_the_same_answer_as_one_block(monkeypatch):
    """The serial call on all poses and the parallel path in blocks of 7 poses answer alike."""
    from impactnet.models.compound import pipeline

    rng = np.random.default_rng(11)
    n = 50
    position_b = np.c_[rng.uniform(-0.1, 0.1, (n, 2)), HEIGHT - rng.uniform(-1e-3, 3e-3, n)]
    quaternion_b = random_quaternions(n, rng) * 0 + [1.0, 0, 0, 0]
    whole = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, position_b, quaternion_b)
    monkeypatch.setattr(pipeline, "ORACLE_CHUNK", 7)
    monkeypatch.setattr(pipeline, "PARALLEL_MIN_ROWS", 1)
    blocks = compound_contacts(FORTY, np.zeros(3), IDENTITY, FORTY, position_b, quaternion_b)
    for name in ("pose", "part_a", "part_b", "offsets"):
        np.testing.assert_array_equal(getattr(blocks, name), getattr(whole, name), err_msg=name)
    for name, column in whole.contacts.arrays().items():
        np.testing.assert_array_equal(blocks.contacts.arrays()[name], column, err_msg=name)
    assert (np.diff(whole.offsets) == 0).any() and len(whole.pose) > n  # both kinds of pose


def _near_poses(rng, n, height, tilt_max, offsets):
    """n poses of B above A: offsets up to ``offsets`` (m, x and y), a tilt up to
    ``tilt_max`` (rad) about a random axis, B's origin ``height`` +- 3 mm high (touching or
    not)."""
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    tilt = rng.uniform(0.0, tilt_max, n)
    quaternion = np.c_[np.cos(tilt / 2), np.sin(tilt / 2)[:, None] * axis]
    position = np.c_[rng.uniform(-offsets[0], offsets[0], n),
                     rng.uniform(-offsets[1], offsets[1], n),
                     height + rng.uniform(-3e-3, 3e-3, n)]
    return position, quaternion


def test_the_touching_test_agrees_with_the_oracle_on_stacking_and_twistlocks():
    """compound_touching (the separating-axis test alone) says a pose touches exactly where the
    oracle finds a part contact: detail-2 stacking and a spreader's heads in the apertures."""
    rng = np.random.default_rng(11)
    container = cb.container("40ft", detail=2)
    height = cb.CONTAINERS["40ft"][2]
    cases = [(container, height, 3e-4, (0.05, 0.05)),
             (cb.spreader("40ft", sides=32),
              height / 2 + cb.SPREADER_FRAME_HEIGHT_ASSUMED / 2, 1e-3, (0.012, 0.005))]
    for body_b, z, tilt, offsets in cases:
        position, quaternion = _near_poses(rng, 300, z, tilt, offsets)
        found = compound_contacts(container, np.zeros(3), [1.0, 0, 0, 0], body_b, position,
                                  quaternion)
        touching = compound_touching(container, np.zeros(3), [1.0, 0, 0, 0], body_b,
                                     position, quaternion)
        expected = np.diff(found.offsets) > 0
        assert 0.2 < expected.mean() < 0.95, expected.mean()  # both kinds of pose
        np.testing.assert_array_equal(touching, expected)
