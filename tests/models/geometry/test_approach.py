"""Tests of impactnet.models.geometry.approach: exact first-touch distance along an approach
direction."""
from __future__ import annotations

import warnings

import fcl
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from impactnet.models.geometry.approach import N_AXES, axis_overlaps, touching_distance

REL = 1e-12  # relative tolerance of the touching condition (times the problem's scale)


def random_pairs(seed, n, size_range=(0.05, 5.0)):
    """Seeded random sizes (log-uniform), uniform rotations and unit directions."""
    rng = np.random.default_rng(seed)
    lo, hi = np.log(size_range[0]), np.log(size_range[1])
    size_a = np.exp(rng.uniform(lo, hi, (n, 3)))
    size_b = np.exp(rng.uniform(lo, hi, (n, 3)))
    rot = Rotation.random(n, random_state=rng).as_matrix()
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return size_a, size_b, rot, d


def scale(size_a, size_b):
    return np.maximum(size_a.max(axis=-1), size_b.max(axis=-1))


# -- analytic cases ------------------------------------------------------------------------

def test_cubes_along_x_touch_at_edge_length():
    s, axis = touching_distance([2, 2, 2], [2, 2, 2], np.eye(3), [1, 0, 0], return_axis=True)
    assert s.shape == (1,)
    assert s[0] == pytest.approx(2.0, rel=1e-15)
    assert axis[0] in (0, 3)  # A's x face (or B's, the same plane)


def test_cubes_along_face_diagonal_touch_at_2_sqrt2():
    d = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    s = touching_distance([2, 2, 2], [2, 2, 2], np.eye(3), d)
    assert s[0] == pytest.approx(2.0 * np.sqrt(2.0), rel=1e-15)


def test_unequal_boxes_along_z():
    s = touching_distance([2, 4, 6], [1, 1, 1], np.eye(3), [0, 0, -1])
    assert s[0] == pytest.approx(3.5, rel=1e-15)


def test_cube_turned_45_about_z_along_x_touches_with_its_vertical_edge():
    rot = Rotation.from_euler("z", 45, degrees=True).as_matrix()
    s = touching_distance([2, 2, 2], [2, 2, 2], rot, [1, 0, 0])
    assert s[0] == pytest.approx(1.0 + np.sqrt(2.0), rel=1e-14)


def test_edge_edge_crossing_touch():
    # A's top ridge (A turned 45 deg about x) and B's bottom ridge (45 deg about y): the cubes
    # touch edge on edge at centre distance 2 sqrt 2 along z; in A's frame.
    rot_a = Rotation.from_euler("x", 45, degrees=True).as_matrix()
    rot_b = Rotation.from_euler("y", 45, degrees=True).as_matrix()
    s, axis = touching_distance([2, 2, 2], [2, 2, 2], rot_a.T @ rot_b, rot_a.T @ [0, 0, 1],
                                return_axis=True)
    assert s[0] == pytest.approx(2.0 * np.sqrt(2.0), rel=1e-14)
    assert axis[0] >= 6  # an edge-edge axis binds


# -- the touching condition on random poses ---------------------------------------------------

def test_touching_condition_on_random_poses():
    size_a, size_b, rot, d = random_pairs(seed=1, n=5000)
    s, axis = touching_distance(size_a, size_b, rot, d, return_axis=True)
    tol = REL * scale(size_a, size_b)
    assert np.all(np.isfinite(s)) and np.all(s > 0)

    at = axis_overlaps(size_a, size_b, rot, s[:, None] * d)
    tight = np.take_along_axis(at, axis[:, None], axis=1)[:, 0]
    assert np.all(np.abs(tight) <= tol)
    assert np.all(at >= -tol[:, None])

    outside = axis_overlaps(size_a, size_b, rot, (s * (1 + 1e-9))[:, None] * d)
    assert np.all(outside.min(axis=1) < 0)  # some axis separates
    inside = axis_overlaps(size_a, size_b, rot, (s * (1 - 1e-9))[:, None] * d)
    assert np.all(inside.min(axis=1) > 0)  # every axis overlaps


def test_agrees_with_fcl_just_inside_and_just_outside():
    size_a, size_b, rot, d = random_pairs(seed=2, n=1000)
    s = touching_distance(size_a, size_b, rot, d)
    request = fcl.CollisionRequest()
    for row in range(len(s)):
        box_a = fcl.CollisionObject(fcl.Box(*size_a[row]), fcl.Transform())
        for factor, expected in ((1 - 1e-9, True), (1 + 1e-9, False)):
            tf_b = fcl.Transform(rot[row], s[row] * factor * d[row])
            box_b = fcl.CollisionObject(fcl.Box(*size_b[row]), tf_b)
            result = fcl.CollisionResult()
            got = fcl.collide(box_a, box_b, request, result) > 0
            assert got == expected, (row, factor)


def test_rows_are_independent_of_the_batch():
    size_a, size_b, rot, d = random_pairs(seed=3, n=50)
    batch = touching_distance(size_a, size_b, rot, d)
    single = [touching_distance(size_a[i], size_b[i], rot[i], d[i])[0] for i in range(50)]
    np.testing.assert_array_equal(batch, single)
    assert batch.dtype == np.float64


def test_overlaps_have_fifteen_axes():
    size_a, size_b, rot, d = random_pairs(seed=4, n=7)
    assert axis_overlaps(size_a, size_b, rot, d).shape == (7, N_AXES)


# -- degenerate configurations ---------------------------------------------------------------

def test_parallel_boxes_skip_degenerate_axes_without_warnings():
    d = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, 0.0, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = touching_distance([[2, 2, 2]] * 3, [[1, 3, 5]] * 3, np.eye(3), d)
        ov = axis_overlaps([2, 2, 2], [1, 3, 5], np.eye(3), [1.5, 0, 0])
    np.testing.assert_allclose(s, [1.5, min(2.5 / 0.6, 3.5 / 0.8), 3.5], rtol=1e-15)
    # Edge i of A is parallel to edge i of B: those cross axes (6, 10, 14) are skipped; the
    # others duplicate face axes.
    assert np.all(np.isinf(ov[0, [6, 10, 14]])) and np.isfinite(ov[0, :6]).all()
    assert not np.isnan(ov).any()


@pytest.mark.parametrize("tilt", [1e-13, 1e-9, 1e-6])
def test_tiny_tilt_is_continuous_with_parallel(tilt):
    rng = np.random.default_rng(5)
    d = rng.standard_normal((200, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    axis = rng.standard_normal((200, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    rot = Rotation.from_rotvec(tilt * axis).as_matrix()
    size_a, size_b = np.array([6.058, 2.438, 2.591]), np.array([12.192, 2.438, 2.591])
    s_tilted = touching_distance(size_a, size_b, rot, d)
    s_parallel = touching_distance(size_a, size_b, np.eye(3), d)
    assert np.all(np.isfinite(s_tilted))
    # Turning B by t moves its surface by at most t |hb|; the first-touch distance of the
    # Minkowski sum (inradius rho, circumradius R about the origin) then moves by at most
    # t |hb| R / rho.
    ha, hb = size_a / 2, size_b / 2
    bound = tilt * np.linalg.norm(hb) * (np.linalg.norm(ha) + np.linalg.norm(hb))
    bound /= ha.min() + hb.min()
    assert np.all(np.abs(s_tilted - s_parallel) <= bound + 1e-12)


# -- invariants (property-based) -------------------------------------------------------------

sizes = st.tuples(*[st.floats(0.01, 100.0)] * 3)
quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1)
directions = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1)


@settings(max_examples=300, deadline=None)
@given(size_a=sizes, size_b=sizes, q=quaternions, v=directions, k=st.floats(0.01, 100.0))
def test_invariants(size_a, size_b, q, v, k):
    size_a, size_b = np.array(size_a), np.array(size_b)
    rot = Rotation.from_quat(q, scalar_first=True).as_matrix()
    d = np.array(v) / np.linalg.norm(v)
    s = touching_distance(size_a, size_b, rot, d)[0]
    assert np.isfinite(s) and s > 0
    # Scaling both boxes scales the distance.
    assert touching_distance(k * size_a, k * size_b, rot, d)[0] == pytest.approx(k * s, rel=1e-12)
    # Seen from B: A approaches along -d, expressed in B's frame.
    s_swapped = touching_distance(size_b, size_a, rot.T, -(rot.T @ d))[0]
    assert s_swapped == pytest.approx(s, rel=1e-12)
    # Bounded by the sum of the circumradii, at least the sum of the inradii.
    assert s <= (np.linalg.norm(size_a) + np.linalg.norm(size_b)) / 2 * (1 + 1e-12)
    assert s >= (size_a.min() + size_b.min()) / 2 * (1 - 1e-12)
