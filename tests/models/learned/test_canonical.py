"""The canonical frame: the exact solver on the canonical pose gives the mapped original
contact; features, targets and labels round-trip."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.box.decision import box_box_matrices
from impactnet.models.box.exact import box_box
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import random_quaternions
from impactnet.models.learned import canonical as cn
from tests.models.helpers import KEYS, labelled_rows

#: Agreement (x pair scale, metres) of two exact solves of the same contact in mirrored
#: frames: sign flips are exact, but the solver's sums meet the flipped terms in another
#: order, so results differ by rounding of the pair's scale.
MIRROR_TOL_REL = 1e-9
#: Share of rows allowed to disagree in type / features between the two solves: ties of the
#: axis choice or of the incident feature (a vertex exactly as deep as its neighbour) resolve
#: by rounding, which a mirror changes.
TIE_SHARE_MAX = 2e-3
SIZES = {"container20/container40": ([6.058, 2.438, 2.591], [12.192, 2.438, 2.591]),
         "spreader/container40hc": ([12.0, 2.35, 0.8], [12.192, 2.438, 2.896]),
         "cube/cube": ([2.0, 2.0, 2.0], [2.0, 2.0, 2.0])}


def _local_solve(half_a, half_b, rotation, translation):
    """The solver on a pose in A's frame: A at the origin, level; B at ``translation`` with the
    matrix ``rotation`` as given (improper for a mirrored frame). The world frame is A's."""
    return box_box_matrices(2.0 * half_a, np.zeros(3), np.eye(3), 2.0 * half_b, translation,
                            rotation)


@pytest.fixture(scope="module", params=sorted(SIZES))
def rows(request):
    size_a, size_b = SIZES[request.param]
    return labelled_rows(size_a, size_b, 20000, 7)


def test_relative_pose_is_the_solvers_local_frame(rows):
    pose = cn.relative_pose(*(rows[k] for k in KEYS))
    rot_a, rot_b = cn.world_rotation(rows["quaternion_a"]), cn.world_rotation(rows["quaternion_b"])
    np.testing.assert_allclose(pose.rotation, np.swapaxes(rot_a, 1, 2) @ rot_b, atol=1e-12)
    offset = rows["position_b"] - rows["position_a"]
    np.testing.assert_allclose(pose.translation, np.einsum("nij,ni->nj", rot_a, offset),
                               atol=1e-12 * np.abs(offset).max())
    np.testing.assert_array_equal(pose.half_a, 0.5 * rows["size_a"])


def test_canonical_pose_lies_in_both_positive_octants(rows):
    pose = cn.relative_pose(*(rows[k] for k in KEYS))
    c = cn.canonicalize(pose.rotation, pose.translation)
    assert (c.translation >= 0).all()
    u = -np.einsum("nij,ni->nj", c.rotation, c.translation)  # A's centre in B's frame
    assert (u >= -1e-12 * np.abs(c.translation).max()).all()
    np.testing.assert_array_equal(c.rotation, c.S[:, :, None] * pose.rotation * c.T[:, None])
    det = np.linalg.det(c.rotation)
    np.testing.assert_allclose(det, np.prod(c.S, 1) * np.prod(c.T, 1), atol=1e-9)


def test_ties_give_plus_one():
    rotation = np.broadcast_to(np.eye(3), (2, 3, 3))
    c = cn.canonicalize(rotation, np.array([[0.0, -0.0, 1.0], [-1.0, 0.0, -0.0]]))
    np.testing.assert_array_equal(c.S, [[1, 1, 1], [-1, 1, 1]])
    np.testing.assert_array_equal(c.T, [[1, 1, -1], [1, 1, 1]])


def test_exact_solver_on_canonical_pose_is_the_mapped_answer(rows):
    pose = cn.relative_pose(*(rows[k] for k in KEYS))
    c = cn.canonicalize(pose.rotation, pose.translation)
    original = _local_solve(*pose)
    mirrored = _local_solve(pose.half_a, pose.half_b, c.rotation, c.translation)
    scale = pose.half_a.max(1) + pose.half_b.max(1)
    tol = MIRROR_TOL_REL * scale
    np.testing.assert_array_equal(mirrored.colliding, original.colliding)
    hit = original.colliding
    np.testing.assert_allclose(mirrored.depth, original.depth, rtol=0, atol=tol.max())
    labels = cn.canonical_labels(original, c.S, c.T)
    same = ((mirrored.contact_type_code == labels.contact_type_code)
            & (mirrored.feature_a == labels.feature_a)
            & (mirrored.feature_b == labels.feature_b))
    assert (~same).mean() <= TIE_SHARE_MAX, np.flatnonzero(~same)[:10]
    ok = same & hit
    normal = c.S * original.normal
    point = c.S * original.point
    assert np.abs(mirrored.normal - normal)[ok].max() <= 1e-9
    assert (np.abs(mirrored.point - point)[ok] <= tol[ok, None]).all()


def test_targets_round_trip_to_the_world(rows):
    pose = cn.relative_pose(*(rows[k] for k in KEYS))
    c = cn.canonicalize(pose.rotation, pose.translation)
    targets = cn.contact_targets(rows["point"], rows["normal"], rows["depth"],
                                 rows["position_a"], rows["quaternion_a"], c, pose.half_a,
                                 pose.half_b)
    assert targets.dtype == np.float32 and targets.shape == (len(pose.half_a), 7)
    point, normal, depth = cn.from_canonical(targets, c.S, pose.half_a, pose.half_b,
                                             rows["position_a"], rows["quaternion_a"])
    scale, edge = cn.pair_lengths(pose.half_a, pose.half_b)
    hit = rows["colliding"]
    assert np.abs(point - rows["point"])[hit].max() <= 1e-6 * scale.max()
    assert np.abs(normal - rows["normal"])[hit].max() <= 1e-6
    assert np.abs(depth - rows["depth"])[hit].max() <= 1e-6 * edge.max()


def test_features_layout(rows):
    pose = cn.relative_pose(*(rows[k] for k in KEYS))
    c = cn.canonicalize(pose.rotation, pose.translation)
    x = cn.pose_features(c, pose.half_a, pose.half_b)
    assert x.dtype == np.float32 and x.shape == (len(c.S), 12)
    scale, _ = cn.pair_lengths(pose.half_a, pose.half_b)
    np.testing.assert_allclose(x[:, :3], c.translation / scale[:, None], rtol=1e-6)
    np.testing.assert_allclose(x[:, 3:], c.rotation.reshape(-1, 9), atol=1e-7)


def test_features_are_invariant_under_rigid_motion(rows):
    rng = np.random.default_rng(3)
    q = random_quaternions(1, rng)[0]
    shift = np.array([1e5, -2e5, 3e4])
    rot = cn.world_rotation(q)[0]
    moved = dict(rows)
    moved["position_a"] = rows["position_a"] @ rot.T + shift
    moved["position_b"] = rows["position_b"] @ rot.T + shift
    w, v = q[0], q[1:]
    for key in ("quaternion_a", "quaternion_b"):  # q * q_body (Hamilton product)
        p = rows[key]
        moved[key] = np.column_stack([w * p[:, 0] - p[:, 1:] @ v,
                                      w * p[:, 1:] + p[:, :1] * v + np.cross(v, p[:, 1:])])
    x0 = cn.learning_arrays(rows).features
    x1 = cn.learning_arrays(moved).features
    flipped = (np.abs(x0[:, :3]) < 1e-6).any(1)  # a sign at a tie may pick the other mirror
    assert np.abs(x1 - x0)[~flipped].max() <= 1e-5


def test_labels_map_back_and_keys_are_canonical(rows):
    pose = cn.relative_pose(*(rows[k] for k in KEYS))
    c = cn.canonicalize(pose.rotation, pose.translation)
    labels = cn.canonical_labels(rows, c.S, c.T)
    assert labels.keys.shape == (len(c.S),)
    np.testing.assert_array_equal(labels.keys == "none", ~rows["colliding"])
    back_a = cn.map_flip_features(bf.sign_flip_index(c.S), labels.feature_a)
    back_b = cn.map_flip_features(bf.sign_flip_index(c.T), labels.feature_b)
    np.testing.assert_array_equal(back_a, rows["feature_a"])
    np.testing.assert_array_equal(back_b, rows["feature_b"])
    for key in np.unique(labels.keys):
        code, fa, fb = cn.parse_region_key(key)
        assert cn.region_key(code, fa, fb) == key
    # B's centre lies in A's positive octant: A's contact feature faces it.
    faces = labels.feature_a[(labels.feature_a >= 0) & (labels.feature_a < 6)]
    assert (faces % 2 == 0).mean() > 0.99


def test_single_row_matches_batch():
    rng = np.random.default_rng(1)
    n = 5
    args = (np.full((n, 3), 2.0), rng.normal(size=(n, 3)), random_quaternions(n, rng),
            np.array([1.0, 2.0, 3.0]), rng.normal(size=(n, 3)), random_quaternions(n, rng))
    batch = cn.relative_pose(*args)
    one = cn.relative_pose(*(a[2] if a.ndim == 2 else a for a in args))
    for b, o in zip(batch, one):
        np.testing.assert_array_equal(b[2:3], o)
    labels = box_box(*args)
    assert len(cn.canonical_labels(labels, cn.canonicalize(batch.rotation, batch.translation).S,
                                   np.ones((n, 3))).keys) == n


@pytest.mark.parametrize("key", ["face-vertex:4", "face-vertex:4:6", "bogus:1:2", "none:1:2",
                                 "edge-edge:6:30", "face-face:a:b", ""])
def test_bad_region_keys_are_refused(key):
    with pytest.raises(ValueError, match="region key"):
        cn.parse_region_key(key)
