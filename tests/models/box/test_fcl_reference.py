"""Sanity tests of the python-fcl wrapper (tests/models/box/fcl_reference.py) on analytic cases.

They pin down the FCL conventions documented in that module's docstring, so that a change of
python-fcl version that alters them fails here first.
"""
from __future__ import annotations

import fcl
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.geometry.approach import axis_overlaps, axis_terms, touching_distance
from tests.models.box.fcl_reference import (
    fcl_box_box,
    fcl_contact_to_impactnet,
    manifold_point,
)

IDENTITY_Q = np.array([1.0, 0.0, 0.0, 0.0])
CUBE = np.array([2.0, 2.0, 2.0])
SQRT2 = np.sqrt(2.0)


def quat(matrix):
    return Rotation.from_matrix(matrix).as_quat(scalar_first=True)


def vertex_down():
    """Rotation taking the (+,+,+) vertex direction of a box to -z."""
    rot, _ = Rotation.align_vectors([[0, 0, -1]], [np.ones(3) / np.sqrt(3)])
    return rot.as_matrix()


def test_resting_stack_of_cubes():
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, [0, 0, 1.9], IDENTITY_Q)
    assert r.colliding.tolist() == [True]
    np.testing.assert_allclose(r.normal[0], [0, 0, 1], atol=1e-15)
    assert r.depth[0] == pytest.approx(0.1, rel=1e-12)
    # 4 contacts: the corners of the shared face, on the mid-surface z = 0.95.
    pts = r.points[0]
    assert pts.shape == (4, 3)
    np.testing.assert_allclose(np.sort(np.abs(pts[:, :2]).ravel()), np.ones(8))
    np.testing.assert_allclose(pts[:, 2], 0.95, rtol=1e-14)
    np.testing.assert_allclose(r.point[0], [0, 0, 0.95], atol=1e-14)


def test_box_takes_full_side_lengths_and_touching_collides():
    z = [[0, 0, 1.99], [0, 0, 2.0], [0, 0, 2.01]]
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, z, IDENTITY_Q)
    assert r.colliding.tolist() == [True, True, False]
    assert r.depth[1] == 0.0 and len(r.depths[2]) == 0
    np.testing.assert_array_equal(r.normal[2], 0.0)


def test_normal_points_from_a_to_b():
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, [[0, 0, -1.9], [1.9, 0, 0]], IDENTITY_Q)
    np.testing.assert_allclose(r.normal, [[0, 0, -1], [1, 0, 0]], atol=1e-15)
    # Swapping the boxes flips it.
    r = fcl_box_box(CUBE, [1.9, 0, 0], IDENTITY_Q, CUBE, [0, 0, 0], IDENTITY_Q)
    np.testing.assert_allclose(r.normal, [[-1, 0, 0]], atol=1e-15)


def test_vertex_of_b_into_face_of_a_lies_on_mid_surface():
    d = 0.05
    centre = np.array([0.1, 0.2, 1 + 0.25 * np.sqrt(3) - d])  # B's lowest vertex at z = 0.95
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, [0.5, 0.5, 0.5], centre, quat(vertex_down()))
    assert len(r.depths[0]) == 1
    c = fcl_contact_to_impactnet(r.normal[0], r.points[0][0], r.depths[0][0])
    np.testing.assert_allclose(c["normal"], [0, 0, 1], atol=1e-15)
    assert c["depth"] == pytest.approx(d, rel=1e-12)
    np.testing.assert_allclose(c["point"], [0.1, 0.2, 0.975], atol=1e-14)
    np.testing.assert_allclose(c["point_on_b"], [0.1, 0.2, 0.95], atol=1e-14)  # B's vertex
    np.testing.assert_allclose(c["point_on_a"], [0.1, 0.2, 1.0], atol=1e-14)  # A's face


def test_vertex_of_a_into_face_of_b_lies_on_mid_surface():
    d = 0.05
    rot_a = Rotation.align_vectors([[0, 0, 1]], [np.ones(3) / np.sqrt(3)])[0].as_matrix()
    vertex = np.array([0.1, -0.2, 0.25 * np.sqrt(3)])
    r = fcl_box_box([0.5, 0.5, 0.5], [0.1, -0.2, 0], quat(rot_a),
                    CUBE, [0, 0, vertex[2] + 1 - d], IDENTITY_Q)
    assert len(r.depths[0]) == 1
    c = fcl_contact_to_impactnet(r.normal[0], r.points[0][0], r.depths[0][0])
    np.testing.assert_allclose(c["normal"], [0, 0, 1], atol=1e-15)
    assert c["depth"] == pytest.approx(d, rel=1e-12)
    np.testing.assert_allclose(c["point_on_a"], vertex, atol=1e-14)  # A's vertex
    np.testing.assert_allclose(c["point"], vertex - [0, 0, d / 2], atol=1e-14)


def test_edge_edge_at_right_angles_gives_the_midpoint_of_the_closest_points():
    d = 0.05
    rot_a = Rotation.from_euler("x", 45, degrees=True).as_matrix()  # ridge along x at z = sqrt 2
    rot_b = Rotation.from_euler("y", 45, degrees=True).as_matrix()  # ridge along y, bottom
    r = fcl_box_box(CUBE, [0, 0, 0], quat(rot_a), CUBE, [0.3, -0.2, 2 * SQRT2 - d], quat(rot_b))
    assert len(r.depths[0]) == 1
    np.testing.assert_allclose(r.normal[0], [0, 0, 1], atol=1e-12)
    # Padded cross-axis radii: too deep by ~10 ulps, never shallower.
    assert d <= r.depth[0] <= d + 1e-13
    np.testing.assert_allclose(r.point[0], [0.3, 0, SQRT2 - d / 2], atol=1e-13)


def test_face_face_manifold_is_culled_to_four_points():
    rot_b = Rotation.from_euler("z", 45, degrees=True).as_matrix()  # clip polygon: octagon
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, [0, 0, 1.95], quat(rot_b), max_contacts=16)
    assert len(r.depths[0]) == 4
    np.testing.assert_allclose(r.points[0][:, 2], 0.975, rtol=1e-14)
    # Fewer requested: FCL keeps the deepest.
    rot_t = Rotation.from_euler("zx", [45, 1], degrees=True).as_matrix()
    full = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, [0, 0, 1.95], quat(rot_t))
    two = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, [0, 0, 1.95], quat(rot_t), max_contacts=2)
    np.testing.assert_allclose(np.sort(two.depths[0]), np.sort(full.depths[0])[-2:])


def test_edge_on_face_gives_the_two_clipped_edge_ends():
    rot_b = Rotation.from_euler("x", 45, degrees=True).as_matrix()  # B's ridge along x, bottom
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, [1, 1, 1], [0.2, 0.1, 1 + np.sqrt(0.5) - 0.05],
                    quat(rot_b))
    np.testing.assert_allclose(r.points[0], [[-0.3, 0.1, 0.975], [0.7, 0.1, 0.975]], atol=1e-14)
    np.testing.assert_allclose(r.depths[0], [0.05, 0.05], rtol=1e-12)


def test_quaternions_are_scalar_first_normalised_and_sign_free():
    q = np.array([np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8)])  # 45 deg about z
    np.testing.assert_allclose(fcl.Transform(q, np.zeros(3)).getRotation(),
                               Rotation.from_quat(q, scalar_first=True).as_matrix(), atol=1e-15)
    # A generic (tilted) pose: for the symmetric octagon of a 45 deg turn, the last bit of
    # the rotation decides which 4 of the 8 equally deep points survive FCL's culling.
    q = Rotation.from_euler("zyx", [30, 2, 1], degrees=True).as_quat(scalar_first=True)
    rows = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, [0, 0, 1.95], [q, -q, 3 * q])
    for k in (1, 2):
        np.testing.assert_allclose(rows.normal[k], rows.normal[0], atol=1e-14)
        np.testing.assert_allclose(rows.points[k], rows.points[0], atol=1e-14)


@pytest.mark.parametrize("seed", range(3))
def test_both_solver_types_take_the_analytic_path(seed):
    rng = np.random.default_rng(seed)
    n = 40
    rot = Rotation.random(n, random_state=rng)
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    s = touching_distance(CUBE, CUBE, rot.as_matrix(), d)
    args = (CUBE, np.zeros(3), IDENTITY_Q, CUBE, (s - 0.05)[:, None] * d,
            rot.as_quat(scalar_first=True))
    libccd = fcl_box_box(*args, solver=fcl.GJKSolverType.GST_LIBCCD)
    indep = fcl_box_box(*args, solver=fcl.GJKSolverType.GST_INDEP)
    assert libccd.colliding.all()
    for a, b in zip(libccd.points, indep.points, strict=True):
        np.testing.assert_array_equal(a, b)


def test_fudge_prefers_a_face_axis_over_a_shallower_edge_axis():
    # Exact: A's z-edge x B's y-edge, normal (1, 1, 0)/sqrt 2, depth 0.2. FCL needs an edge axis
    # 5 % shallower than the best face axis and reports B's x face normal instead, 5 deg off.
    rot_b = Rotation.from_euler("xyz", [0, 5, 45], degrees=True).as_matrix()
    d = np.array([1.0, 1.0, 0.0]) / SQRT2
    s = touching_distance(CUBE, CUBE, rot_b, d)[0]
    t = (s - 0.2) * d
    over = axis_overlaps(CUBE, CUBE, rot_b, t)[0]
    assert np.argmin(over) == 13 and over.min() == pytest.approx(0.2, rel=1e-12)
    r = fcl_box_box(CUBE, [0, 0, 0], IDENTITY_Q, CUBE, t, quat(rot_b))
    np.testing.assert_allclose(r.normal[0], rot_b[:, 0], atol=1e-12)
    assert over[3] / over[13] == pytest.approx(1.0358, abs=1e-4)  # within the 5 % factor
    assert np.degrees(np.arccos(r.normal[0] @ d)) == pytest.approx(5.0, abs=1e-9)
    assert r.depth[0] == pytest.approx(0.20076, abs=1e-5)


def test_edge_edge_depth_excess_matches_the_scale_aware_pad():
    rng = np.random.default_rng(11)
    n = 300
    size_a, size_b = rng.uniform(2, 30, (n, 3)), rng.uniform(2, 30, (n, 3))
    rot = Rotation.random(n, random_state=rng).as_matrix()
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    s = touching_distance(size_a, size_b, rot, d)
    t = (s - 0.1)[:, None] * d
    over = axis_overlaps(size_a, size_b, rot, t)
    best = over.argmin(axis=1)
    q = Rotation.from_matrix(rot).as_quat(scalar_first=True)
    r = fcl_box_box(size_a, np.zeros(3), IDENTITY_Q, size_b, t, q)
    axes, _, length, _ = axis_terms(size_a, size_b, rot)
    unit = axes / length[..., None]
    picked = np.abs(np.einsum("nkc,nc->nk", unit, r.normal)).argmax(axis=1)
    edge = (best >= 6) & (picked == best)
    assert edge.sum() > 50
    i, j = np.divmod(best[edge] - 6, 3)
    other = np.array([[1, 2], [0, 2], [0, 1]])
    ha, hb = size_a[edge] / 2, size_b[edge] / 2
    rows = np.arange(edge.sum())
    pad = 10 * np.finfo(float).eps * np.maximum(1.0, np.maximum(ha.max(1), hb.max(1)))
    spread = (ha[rows, other[i, 0]] + ha[rows, other[i, 1]]
              + hb[rows, other[j, 0]] + hb[rows, other[j, 1]])
    predicted = pad * spread / length[edge, best[edge]]
    excess = r.depth[edge] - over[edge, best[edge]]
    assert np.median(excess / predicted) == pytest.approx(1.0, abs=0.01)
    assert excess.min() > 0


def test_manifold_point_weights_by_depth():
    pts = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    np.testing.assert_allclose(manifold_point(pts, [1.0, 3.0]), [0.75, 0, 0])
    np.testing.assert_allclose(manifold_point(pts, [0.0, 0.0]), [0.5, 0, 0])
