"""Tests of impactnet.models.geometry.poses: seeded first-contact pose sampler."""
from __future__ import annotations

import fcl
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.geometry.approach import axis_overlaps, axis_terms, touching_distance
from impactnet.models.geometry.poses import (
    AXIS_ALIGNED_ROTATIONS,
    ORIENTATIONS,
    SIZE_FAMILIES,
    TILT_RANGE,
    first_contact_poses,
)

KEYS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b",
        "direction", "push_depth", "touch_distance", "separated")


def matrices(q):
    return Rotation.from_quat(q, scalar_first=True).as_matrix()


def relative(poses):
    """R_ab (n,3,3) and B's centre in A's frame (n,3) from the world arrays."""
    rot_a = matrices(poses["quaternion_a"])
    rot_ab = np.swapaxes(rot_a, 1, 2) @ matrices(poses["quaternion_b"])
    offset = np.einsum("nji,nj->ni", rot_a, poses["position_b"] - poses["position_a"])
    return rot_ab, offset


def min_overlap(poses):
    rot_ab, offset = relative(poses)
    return axis_overlaps(poses["size_a"], poses["size_b"], rot_ab, offset).min(axis=1)


def tolerance(poses):
    """Round-off allowance in metres: relative to the pair scale and to the world offset."""
    scale = np.maximum(poses["size_a"].max(1), poses["size_b"].max(1))
    return 1e-12 * scale + 8 * np.finfo(float).eps * np.abs(poses["position_a"]).max(1)


def misalignment(rot_ab):
    """Angle (rad) from R_ab to the nearest of the 24 axis-aligned rotations."""
    rel = np.einsum("nij,kij->nk", rot_ab, AXIS_ALIGNED_ROTATIONS)  # trace(P^T R)
    return np.arccos(np.clip((rel.max(axis=1) - 1) / 2, -1, 1))


@pytest.mark.parametrize("orientation", ORIENTATIONS)
def test_same_seed_same_bytes(orientation):
    kw = dict(separated_share=0.3, orientation=orientation, world_offset=1e6)
    a = first_contact_poses(500, *SIZE_FAMILIES["container20_40"], rng=7, **kw)
    b = first_contact_poses(500, *SIZE_FAMILIES["container20_40"],
                            rng=np.random.default_rng(7), **kw)
    c = first_contact_poses(500, *SIZE_FAMILIES["container20_40"], rng=8, **kw)
    assert set(a) == set(KEYS)
    for k in KEYS:
        assert a[k].tobytes() == b[k].tobytes(), k
    assert a["position_b"].tobytes() != c["position_b"].tobytes()


def test_shapes_and_conventions():
    n = 300
    p = first_contact_poses(n, [1, 2, 3], [[4, 5, 6]] * n, rng=0, world_offset=[1, 2, 3])
    for k in ("size_a", "position_a", "size_b", "position_b", "direction"):
        assert p[k].shape == (n, 3) and p[k].dtype == np.float64
    for k in ("quaternion_a", "quaternion_b"):
        assert p[k].shape == (n, 4)
        np.testing.assert_allclose(np.linalg.norm(p[k], axis=1), 1, atol=1e-15)
        assert (p[k][:, 0] >= 0).all()
    np.testing.assert_array_equal(p["position_a"], np.broadcast_to([1.0, 2.0, 3.0], (n, 3)))
    np.testing.assert_allclose(np.linalg.norm(p["direction"], axis=1), 1, atol=1e-15)
    centre = p["position_a"] + (p["touch_distance"] - p["push_depth"])[:, None] * p["direction"]
    np.testing.assert_allclose(p["position_b"], centre, atol=1e-14)


@pytest.mark.parametrize("family", sorted(SIZE_FAMILIES))
@pytest.mark.parametrize("orientation", ORIENTATIONS)
def test_contact_share_touches_at_the_drawn_depth(family, orientation):
    p = first_contact_poses(400, *SIZE_FAMILIES[family], rng=1, orientation=orientation,
                            world_offset=1e6)
    depth = p["push_depth"]
    shortest = np.minimum(p["size_a"].min(1), p["size_b"].min(1))
    assert (depth >= 0).all() and (depth <= 0.01 * shortest).all()
    over, tol = min_overlap(p), tolerance(p)
    # Pushed in by `depth` along the approach: the binding axis overlaps by |n.d| depth, so
    # the SAT penetration lies in [0, depth].
    assert (over >= -tol).all()
    assert (over <= depth + tol).all()
    # On the axis that binds at first touch the overlap is exactly |n.d| depth.
    rot_ab, offset = relative(p)
    d_local = np.einsum("nji,nj->ni", matrices(p["quaternion_a"]), p["direction"])
    _, axis = touching_distance(p["size_a"], p["size_b"], rot_ab, d_local, return_axis=True)
    axes, _, length, _ = axis_terms(p["size_a"], p["size_b"], rot_ab)
    unit = np.take_along_axis(axes, axis[:, None, None], 1)[:, 0] / np.take_along_axis(
        length, axis[:, None], 1)
    on_axis = np.take_along_axis(
        axis_overlaps(p["size_a"], p["size_b"], rot_ab, offset), axis[:, None], 1)[:, 0]
    expected = np.abs(np.einsum("nc,nc->n", unit, d_local)) * depth
    assert (np.abs(on_axis - expected) <= tol).all()


@pytest.mark.parametrize("orientation", ORIENTATIONS)
def test_zero_depth_touches_exactly(orientation):
    p = first_contact_poses(300, *SIZE_FAMILIES["slab"], rng=2, depth_fraction=(0.0, 0.0),
                            orientation=orientation)
    assert np.abs(min_overlap(p)).max() <= tolerance(p).max()


@pytest.mark.parametrize("orientation", ORIENTATIONS)
def test_separated_share_is_separated(orientation):
    n = 1000
    p = first_contact_poses(n, *SIZE_FAMILIES["needle"], rng=3, depth_fraction=(1e-3, 1e-2),
                            separated_share=0.25, orientation=orientation)
    sep = p["separated"]
    assert sep.sum() == 250
    assert (p["push_depth"][sep] < 0).all() and (p["push_depth"][~sep] > 0).all()
    over = min_overlap(p)
    assert (over[sep] < 0).all()
    assert (over[~sep] > 0).all()


def test_fcl_agrees_with_contact_and_separated_labels():
    p = first_contact_poses(300, *SIZE_FAMILIES["container20"], rng=4,
                            depth_fraction=(1e-3, 1e-2), separated_share=0.5)
    request = fcl.CollisionRequest()
    for i in range(300):
        boxes = [fcl.CollisionObject(fcl.Box(*p[f"size_{s}"][i]),
                                     fcl.Transform(p[f"quaternion_{s}"][i], p[f"position_{s}"][i]))
                 for s in "ab"]
        hit = fcl.collide(*boxes, request, fcl.CollisionResult()) > 0
        assert hit == (not p["separated"][i]), i


def test_near_parallel_faces_are_nearly_parallel():
    p = first_contact_poses(2000, *SIZE_FAMILIES["cube"], rng=5, orientation="near_parallel_faces")
    angle = misalignment(relative(p)[0])
    assert angle.max() <= TILT_RANGE[1] * (1 + 1e-9)
    # log-uniform tilt: about a third of the decades lie below 1e-6 rad.
    assert 0.3 < np.mean(angle < 1e-6) < 0.55
    # all 24 axis-aligned rotations occur.
    nearest = np.einsum("nij,kij->nk", relative(p)[0], AXIS_ALIGNED_ROTATIONS).argmax(axis=1)
    assert len(np.unique(nearest)) == 24


def test_near_parallel_edges_have_one_nearly_parallel_edge_pair():
    p = first_contact_poses(2000, *SIZE_FAMILIES["container20_40"], rng=6,
                            orientation="near_parallel_edges")
    rot_ab = relative(p)[0]
    # One of B's axes is within the tilt range of one of A's axes ...
    assert np.abs(rot_ab).max(axis=(1, 2)).min() >= np.cos(TILT_RANGE[1]) - 1e-12
    # ... while the pair is, as a rule, not face-parallel.
    assert np.median(misalignment(rot_ab)) > 0.1


def test_paper_orientation_uses_euler_ranges():
    p = first_contact_poses(2000, *SIZE_FAMILIES["cube"], rng=7, orientation="paper")
    yaw, pitch, roll = Rotation.from_matrix(relative(p)[0]).as_euler("ZYX").T
    for angle in (yaw, pitch, roll):
        assert angle.min() >= -np.pi / 2 - 1e-9 and angle.max() <= np.pi / 2 + 1e-9
        assert angle.min() < -1.4 and angle.max() > 1.4


def test_uniform_orientations_and_directions_are_unbiased():
    n = 20000
    p = first_contact_poses(n, *SIZE_FAMILIES["cube"], rng=8)
    rot_ab = relative(p)[0]
    # Haar measure: E[R] = 0 and E[R_ij^2] = 1/3.
    assert np.abs(rot_ab.mean(axis=0)).max() < 5 / np.sqrt(n)
    np.testing.assert_allclose((rot_ab ** 2).mean(axis=0), 1 / 3, atol=5 / np.sqrt(n))
    assert np.abs(p["direction"].mean(axis=0)).max() < 5 / np.sqrt(n)


def test_size_families():
    for name in ("cube", "container20", "container20_40", "container40", "slab", "needle"):
        assert name in SIZE_FAMILIES
    assert SIZE_FAMILIES["container40"][0] == (12.192, 2.438, 2.591)
    aspects = [max(s) / min(s) for pair in SIZE_FAMILIES.values() for s in pair]
    assert min(min(s) for pair in SIZE_FAMILIES.values() for s in pair) > 0
    assert max(aspects) >= 1e4


def test_unknown_orientation_is_rejected():
    with pytest.raises(ValueError, match="orientation"):
        first_contact_poses(3, [1, 1, 1], [1, 1, 1], rng=0, orientation="sideways")
