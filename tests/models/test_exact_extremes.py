"""Exact solver at the numerical extremes: parallel faces and edges, huge coordinates, tiny and
huge boxes, needles, gimbal lock. Every answer must be finite."""
import numpy as np
import pytest

from models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from models.exact import InvalidBoxError, box_box
from models.rotations import euler_to_matrix, euler_to_quaternion, matrix_to_quaternion
from tests.models.helpers import assert_finite

IDENTITY = [1.0, 0.0, 0.0, 0.0]
TILTS = [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3]
#: Depth (metres) of the tilt scenarios: B (a 1 m cube) pressed 5 mm into A's top face.
PRESS = 0.005


def expected_tilted_face_point(tilt, axis):
    """Depth-weighted mean of B's four bottom corners on the mid-surface (A's face reference).

    B: unit cube, centre (0, 0, 1.5 - PRESS), tilted by `tilt` radians about the unit `axis`;
    A: cube of edge 2 at the origin, top face z = 1. Independent of the solver's code.
    """
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + np.sin(tilt) * k + (1 - np.cos(tilt)) * k @ k
    signs = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]])
    corners = np.array([rot @ [0.5 * a, 0.5 * b, -0.5] for a, b in signs])
    corners += [0, 0, 1.5 - PRESS]
    depth = 1.0 - corners[:, 2]
    mid = corners + np.outer(0.5 * depth, [0, 0, 1])
    return (depth[:, None] * mid).sum(0) / depth.sum(), rot


@pytest.mark.parametrize("axis", [np.array([0.0, 1.0, 0.0]), np.array([0.6, 0.8, 0.0])])
def test_tilt_through_parallel_faces_moves_point_and_normal_continuously(axis):
    points, normals = [], []
    for tilt in TILTS:
        expected, rot = expected_tilted_face_point(tilt, axis)
        c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1, 1], [0, 0, 1.5 - PRESS],
                    matrix_to_quaternion(rot)[0])
        assert_finite(c)
        assert c.contact_type[0] == "face-face"
        # Either face may be the reference (they tie at tilt 0): the normal is within the tilt.
        assert np.arccos(min(1.0, c.normal[0] @ [0, 0, 1])) <= tilt + 1e-12
        # Switching reference moves the point by O(tilt * depth), far below tilt * size.
        np.testing.assert_allclose(c.point[0], expected, atol=1e-12 + tilt * 1.0)
        points.append(c.point[0])
        normals.append(c.normal[0])
    for i in range(1, len(TILTS)):
        # Continuity: no jump larger than the tilt times the size (1 m) times the lever L / depth.
        bound = 1e-12 + TILTS[i] * 1.0 * (1.0 / PRESS)
        assert np.linalg.norm(points[i] - points[0]) <= bound
        assert np.linalg.norm(normals[i] - normals[0]) <= TILTS[i] + 1e-12


@pytest.mark.parametrize("tilt", TILTS)
def test_near_parallel_edges_give_finite_face_contact(tilt):
    # A and B rolled 45 degrees about x: two ridges along x, one above the other; B yawed by
    # `tilt` so the edges are near-parallel. With equal orientation the contact is face-face.
    qa = euler_to_quaternion([np.pi / 4, 0, 0])[0]
    qb = euler_to_quaternion([np.pi / 4, 0, tilt])[0]
    gap = 2 * np.sqrt(2.0) - 0.01
    c = box_box([2, 2, 2], [0, 0, 0], qa, [2, 2, 2], [0.3, 0, gap], qb)
    assert_finite(c)
    assert c.colliding[0]
    # The least-penetration direction is one of the rolled face normals (45 degrees).
    assert abs(c.normal[0, 2]) == pytest.approx(np.sqrt(0.5), abs=1e-3 + tilt)
    assert c.depth[0] == pytest.approx(0.01 / np.sqrt(2.0), rel=1e-6, abs=tilt * 2)


@pytest.mark.parametrize("tilt", TILTS)
def test_near_parallel_edge_on_face_stays_face_edge(tilt):
    qb = euler_to_quaternion([np.pi / 4 + tilt, tilt, 0])[0]
    c = box_box([3, 3, 2], [0, 0, 0], IDENTITY, [1, 2, 2], [0, 0, 1 + np.sqrt(2) - 0.01], qb)
    assert_finite(c)
    assert c.contact_type[0] in ("face-edge", "face-vertex")
    # The 1 m edge tilts by `tilt` along its length: its ends' depths differ by `tilt` m, which
    # moves the depth-weighted point by at most tilt * length * (length / depth).
    np.testing.assert_allclose(c.point[0], [0, 0, 0.995], atol=1e-12 + tilt * 1.0 / 0.01)


@pytest.mark.parametrize("offset", [1e3, 1e6])
def test_huge_coordinates_give_the_origin_answer(offset):
    rng = np.random.default_rng(3)
    q = rng.normal(size=(200, 4))
    direction = rng.normal(size=(200, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    pos_b = 1.6 * direction
    far = np.array([offset, -offset, 0.5 * offset])
    near = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1.5, 1], pos_b, q)
    away = box_box([2, 2, 2], far, IDENTITY, [1, 1.5, 1], pos_b + far, q)
    assert_finite(away)
    assert (near.colliding == away.colliding).all()
    # Positions at 1e6 m are known to ~1e-10 m; the answer must be as good as the input.
    tol = 64 * np.spacing(offset)
    np.testing.assert_allclose(away.depth, near.depth, atol=tol)
    np.testing.assert_allclose(away.normal, near.normal, atol=tol)
    np.testing.assert_allclose(away.point - far, near.point, atol=tol)
    np.testing.assert_array_equal(away.contact_type_code, near.contact_type_code)


@pytest.mark.parametrize("scale", [1e-3, 1e-1, 1e1, 1e3])
def test_box_scale_from_a_millimetre_to_a_kilometre_scales_the_answer(scale):
    rng = np.random.default_rng(4)
    q = rng.normal(size=(200, 4))
    direction = rng.normal(size=(200, 3))
    pos_b = 1.6 * direction / np.linalg.norm(direction, axis=1, keepdims=True)
    unit = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1.5, 1], pos_b, q)
    scaled = box_box(np.array([2, 2, 2]) * scale, [0, 0, 0], IDENTITY,
                     np.array([1, 1.5, 1]) * scale, pos_b * scale, q)
    assert_finite(scaled)
    np.testing.assert_array_equal(scaled.colliding, unit.colliding)
    np.testing.assert_allclose(scaled.depth, unit.depth * scale, rtol=1e-9, atol=1e-12 * scale)
    np.testing.assert_allclose(scaled.point, unit.point * scale, rtol=1e-9, atol=1e-12 * scale)
    np.testing.assert_allclose(scaled.normal, unit.normal, atol=1e-9)


@pytest.mark.parametrize("aspect", [1e2, 1e3, 1e4])
def test_needle_across_a_box_top_touches_at_its_middle(aspect):
    # A needle of length 10 m and thickness 10 / aspect lies across a 2 m cube, pressed 1 %
    # of its thickness into the top face, yawed 30 degrees and rolled slightly.
    thick = 10.0 / aspect
    press = 0.01 * thick
    q = euler_to_quaternion([1e-3, 0, np.pi / 6])[0]
    rot = euler_to_matrix([1e-3, 0, np.pi / 6])[0]
    half_height = 0.5 * thick * (abs(rot[2, 1]) + abs(rot[2, 2])) + 5.0 * abs(rot[2, 0])
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [10, thick, thick],
                [0.1, 0.2, 1 + half_height - press], q)
    assert_finite(c)
    assert c.colliding[0]
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-9)
    assert c.depth[0] == pytest.approx(press, rel=1e-6)
    # The roll lifts one long bottom edge by thick * sin(roll): the manifold has two depths.
    shallow = press - thick * np.sin(1e-3)
    mean_depth = (press**2 + shallow**2) / (press + shallow)
    assert c.point[0, 2] == pytest.approx(1 - mean_depth / 2, abs=1e-9 * thick)
    assert c.contact_type[0] == "face-face"


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
def test_euler_input_at_gimbal_lock_matches_the_matrix(pitch):
    euler = np.array([0.3, pitch, -0.7])
    q_euler = euler_to_quaternion(euler)[0]
    q_matrix = matrix_to_quaternion(euler_to_matrix(euler))[0]
    a = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1, 1], [0.2, 0.1, 1.7], q_euler)
    b = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1, 1], [0.2, 0.1, 1.7], q_matrix)
    assert_finite(a)
    np.testing.assert_allclose(a.point, b.point, atol=1e-12)
    np.testing.assert_allclose(a.normal, b.normal, atol=1e-12)
    assert a.contact_type_code[0] == b.contact_type_code[0]


@pytest.mark.parametrize("field,value", [
    ("size_a", [1e-7, 1, 1]), ("size_b", [1, 1, 2e6]), ("size_a", [1e300, 1, 1]),
    ("position_b", [0, 0, 2e9]),
])
def test_inputs_outside_the_domain_are_refused_with_the_field(field, value):
    args = dict(size_a=[1, 1, 1], position_a=[0, 0, 0], quaternion_a=IDENTITY,
                size_b=[1, 1, 1], position_b=[0, 0, 0.9], quaternion_b=IDENTITY)
    for batch in (False, True):
        args[field] = np.array([value, value]) if batch else value
        with pytest.raises(InvalidBoxError) as info:
            box_box(**args)
        assert info.value.field == field


def test_the_edges_of_the_domain_give_finite_answers():
    # Every combination of the smallest and largest boxes, at the farthest positions, in
    # random orientations: the answers are finite on both paths.
    rng = np.random.default_rng(11)
    n = 4000
    size_a = 10.0 ** rng.uniform(np.log10(SIZE_MIN_M), np.log10(SIZE_MAX_M), (n, 3))
    size_b = np.where(rng.random((n, 1)) < 0.5, SIZE_MIN_M, SIZE_MAX_M) * rng.uniform(1, 2, (n, 3))
    size_b = np.clip(size_b, SIZE_MIN_M, SIZE_MAX_M)
    position_a = rng.choice([-1.0, 1.0], (n, 3)) * POSITION_MAX_M * rng.uniform(0.5, 1, (n, 3))
    position_b = np.clip(position_a + rng.normal(size=(n, 3)) * size_a.max(1, keepdims=True),
                         -POSITION_MAX_M, POSITION_MAX_M)
    qa, qb = rng.normal(size=(n, 4)), rng.normal(size=(n, 4))
    assert_finite(box_box(size_a, position_a, qa, size_b, position_b, qb))
    for i in range(0, n, 40):
        assert_finite(box_box(size_a[i], position_a[i], qa[i], size_b[i], position_b[i], qb[i]))
