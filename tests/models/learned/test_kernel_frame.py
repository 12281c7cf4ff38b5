"""The compiled canonical frame (impactnet.models.learned.kernel_frame) against the reference
functions training uses (impactnet.models.learned.canonical): the same features and sign flips
to the last bit, far from the origin and from unnormalised quaternions; its inverse maps the
targets back to the exact contacts; a short normal falls back."""
from __future__ import annotations

import numba
import numpy as np
import pytest

from impactnet.models.box.exact import box_box, checked_rows
from impactnet.models.box.kernel_views import pair_frame
from impactnet.models.geometry import box_features as bf
from impactnet.models.learned import canonical as cn
from impactnet.models.learned.kernel_frame import canonical, normal_to_world, point_to_world
from tests.models.helpers import KEYS, labelled_rows

SIZE_A, SIZE_B = [6.058, 2.438, 2.591], [12.0, 2.35, 0.8]
#: Agreement of a contact mapped to the canonical frame and back with the exact one: float64
#: rounding of a few operations on coordinates of magnitude 1e5 m (the far shift below).
ROUND_TRIP_REL = 1e-14


@numba.njit
def _features(inputs, scale, features, flips):
    for i in range(features.shape[0]):
        frame = pair_frame(inputs, i)[2]
        _, _, flips[i, 0], flips[i, 1] = canonical(frame[2], frame[3], frame[4], scale,
                                                   features[i])


@numba.njit
def _to_world(inputs, scale, targets, point, normal):
    for i in range(targets.shape[0]):
        position, rot_a, frame = pair_frame(inputs, i)
        signs = canonical(frame[2], frame[3], frame[4], scale, np.empty(12))[0]
        p = point_to_world(position, rot_a, signs, targets[i], 0, scale)
        n = normal_to_world(rot_a, signs, targets[i], 0)
        for c in range(3):
            point[i, c], normal[i, c] = p[c], n[c]


@pytest.fixture(scope="module")
def rows():
    rows = labelled_rows(SIZE_A, SIZE_B, 3000, 4)
    rng = np.random.default_rng(0)
    shift = rng.normal(size=3) * 1e5  # far from the origin: the offset is taken in float64
    for key in ("position_a", "position_b", "point"):
        rows[key] = rows[key] + shift
    rows["quaternion_a"] = rows["quaternion_a"] * rng.uniform(0.5, 3.0, (3000, 1))  # unnormalised
    return rows


def test_features_and_flips_are_the_references_to_the_last_bit(rows):
    args = [rows[k] for k in KEYS]
    pose = cn.relative_pose(*args)
    c = cn.canonicalize(pose.rotation, pose.translation)
    scale = float(pose.half_a[0].max() + pose.half_b[0].max())
    reference = np.concatenate([c.translation / scale, c.rotation.reshape(-1, 9)], axis=1)
    features, flips = np.empty((3000, 12)), np.empty((3000, 2), np.int64)
    _features(tuple(checked_rows(*args)[0]), scale, features, flips)
    np.testing.assert_array_equal(features, reference)  # float64, before pose-v1's float32
    np.testing.assert_array_equal(features.astype(np.float32),
                                  cn.pose_features(c, pose.half_a, pose.half_b))
    np.testing.assert_array_equal(flips[:, 0], bf.sign_flip_index(c.S))
    np.testing.assert_array_equal(flips[:, 1], bf.sign_flip_index(c.T))


def test_ties_give_plus_one():
    features, flips = np.empty((1, 12)), np.empty((1, 2), np.int64)
    inputs = tuple(np.atleast_2d(np.asarray(v, np.float64)) for v in (
        [1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0, 0, 0], [1.0, 1.0, 1.0], [-0.0, 0.0, 0.9],
        [1.0, 0, 0, 0]))
    _features(inputs, 1.0, features, flips)
    assert flips.tolist() == [[0, 1]]  # S = +1 (t = (0, 0, 0.9)); u = -t: T = (1, 1, -1)


def test_the_inverse_maps_the_targets_back_to_the_exact_contacts(rows):
    args = [rows[k] for k in KEYS]
    pose = cn.relative_pose(*args)
    c = cn.canonicalize(pose.rotation, pose.translation)
    exact = box_box(*args)
    scale = float(pose.half_a[0].max() + pose.half_b[0].max())
    local_point = np.einsum("nij,ni->nj", cn.world_rotation(rows["quaternion_a"]),
                            exact.point - rows["position_a"])
    local_normal = np.einsum("nij,ni->nj", cn.world_rotation(rows["quaternion_a"]),
                             exact.normal)
    targets = np.concatenate([c.S * local_point / scale, c.S * local_normal], axis=1)
    point, normal = np.empty((3000, 3)), np.empty((3000, 3))
    _to_world(tuple(checked_rows(*args)[0]), scale, targets, point, normal)
    hit = exact.colliding
    np.testing.assert_allclose(normal[hit], exact.normal[hit], rtol=0, atol=ROUND_TRIP_REL * 10)
    magnitude = np.abs(rows["position_a"]).max()
    np.testing.assert_allclose(point[hit], exact.point[hit], rtol=0,
                               atol=ROUND_TRIP_REL * magnitude)


def test_a_short_normal_falls_back():
    inputs = tuple(np.atleast_2d(np.asarray(v, np.float64)) for v in (
        SIZE_A, [0.0, 0.0, 0.0], [1.0, 0, 0, 0], SIZE_B, [0.1, 0.2, 2.0], [1.0, 0, 0, 0]))
    point, normal = np.empty((1, 3)), np.empty((1, 3))
    _to_world(inputs, 1.0, np.array([[0.1, 0.2, 0.3, 1e-7, 0.0, 0.0]]), point, normal)
    np.testing.assert_array_equal(normal[0], cn.FALLBACK_NORMAL)  # A level, S = +1
    assert np.isfinite(point).all()
