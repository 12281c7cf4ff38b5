"""Exact solver at the numerical extremes: parallel faces and edges, huge coordinates, tiny and
huge boxes, needles, gimbal lock. Every answer must be finite.

The points of the tilted face contacts are checked against docs/design.md's centre of pressure
integrated exactly over polyhedra (``tests/models/box/overlap_volume.py``, no solver code), with
the solver's pressure floor (:data:`impactnet.models.box.pressure.PRESSURE_FLOOR_REL`) reproduced.
"""
import numpy as np
import pytest

from impactnet.models.box.exact import InvalidBoxError, box_box
from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL
from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry.rotations import (
    euler_to_matrix,
    euler_to_quaternion,
    matrix_to_quaternion,
    quaternion_to_matrix,
)
from tests.models.box.overlap_volume import centre_of_pressure
from tests.models.helpers import assert_finite

IDENTITY = [1.0, 0.0, 0.0, 0.0]
TILTS = [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3]
#: Depth (metres) of the tilt scenarios: B (a 1 m cube) pressed 5 mm into A's top face.
PRESS = 0.005
#: Agreement of the solver's point with the polyhedral integration (x the pair's largest edge,
#: metres): two float64 evaluations of the same integral in different orders; measured
#: <= 1.5e-13 of the edge (the 10 m needle at aspect 1e4).
COP_TOL_REL = 1e-12
UP = np.array([0.0, 0.0, 1.0])


def rule_point(size_a, size_b, position_b, quaternion_b):
    """docs/design.md's point of B pressed into the top face of A (axis-aligned at the origin), with
    the solver's pressure floor (PRESSURE_FLOOR_REL x the sum of the largest half-extents)."""
    floor = PRESSURE_FLOOR_REL * 0.5 * (max(size_a) + max(size_b))
    rot_b = quaternion_to_matrix(np.atleast_2d(quaternion_b))[0]
    return centre_of_pressure((size_a, np.zeros(3), np.eye(3)), (size_b, position_b, rot_b), UP,
                              floor)


def tilted_cube_quaternion(tilt, axis):
    """Rotation by ``tilt`` radians about the unit ``axis`` (Rodrigues), as a quaternion."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return matrix_to_quaternion(np.eye(3) + np.sin(tilt) * k + (1 - np.cos(tilt)) * k @ k)[0]


@pytest.mark.parametrize("axis", [np.array([0.0, 1.0, 0.0]), np.array([0.6, 0.8, 0.0])])
def test_tilt_through_parallel_faces_moves_point_and_normal_continuously(axis):
    """B (1 m cube) 5 mm into A's top face (2 m cube), tilted about a horizontal axis. A's face
    is the least overlap (B's face axis gains twice as much overlap per radian of tilt), so
    it is the reference: the point is the centre of pressure of B's bottom face (and of the
    side faces that tilt towards A), tilt / (12 PRESS) m from the 1 m face's centre, a third
    of the offset of a mean over its four corners (tilt / (4 PRESS))."""
    points, normals = [], []
    for tilt in TILTS:
        q = tilted_cube_quaternion(tilt, axis)
        position_b = np.array([0.0, 0.0, 1.5 - PRESS])
        c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1, 1], position_b, q)
        assert_finite(c)
        assert c.contact_type[0] == "face-face"
        np.testing.assert_array_equal(c.normal[0], UP)
        expected = rule_point([2.0, 2, 2], [1.0, 1, 1], position_b, q)
        np.testing.assert_allclose(c.point[0], expected, rtol=0, atol=COP_TOL_REL * 2.0)
        points.append(c.point[0])
        normals.append(c.normal[0])
    for i in range(1, len(TILTS)):
        # Continuity: the point moves by about tilt x size (1 m) x size / (12 depth).
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
    """B (1 x 2 x 2) rolled 45 degrees stands on its 1 m x edge 10 mm deep in A's top face,
    rolled and pitched by ``tilt`` more. Level, the depth profile is a tent of half-width
    10 mm along the edge: the point is the edge's middle, depth / 3 below the face. Tilted,
    the edge's ends differ in depth by ``tilt`` m and the point follows the exact integral."""
    qb = euler_to_quaternion([np.pi / 4 + tilt, tilt, 0])[0]
    position_b = np.array([0.0, 0.0, 1 + np.sqrt(2) - 0.01])
    c = box_box([3, 3, 2], [0, 0, 0], IDENTITY, [1, 2, 2], position_b, qb)
    assert_finite(c)
    assert c.contact_type[0] in ("face-edge", "face-vertex")
    expected = rule_point([3.0, 3, 2], [1.0, 2, 2], position_b, qb)
    np.testing.assert_allclose(c.point[0], expected, rtol=0, atol=COP_TOL_REL * 3.0)
    # The tent's centroid, to the floor's shift (tau / 6 for a tent) and the tilt's: the ends'
    # depths differ by tilt x length, which moves the point by at most tilt x length x
    # (length / depth).
    floor = PRESSURE_FLOOR_REL * 2.5
    np.testing.assert_allclose(c.point[0], [0, 0, 1 - 0.01 / 3],
                               atol=floor / 6 + 1e-12 + tilt * 1.0 * (1.0 / 0.01))


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
    """A needle of length 10 m and thickness 10 / aspect lies across a 2 m cube, pressed 1 %
    of its thickness into the top face, yawed 30 degrees and rolled by 1e-3 rad: the roll
    lifts one long bottom edge by thick sin(roll), so the depth runs linearly from p to s
    across the needle. Cut by the cube's sides into a parallelogram whose every cross-section
    has the same profile, the centre of pressure is (p^2 + p s + s^2) / (3 (p + s)) below the
    face (the 1-D linear profile), plus the sliver of the side face the roll turns down."""
    thick = 10.0 / aspect
    press = 0.01 * thick
    roll = 1e-3
    q = euler_to_quaternion([roll, 0, np.pi / 6])[0]
    rot = euler_to_matrix([roll, 0, np.pi / 6])[0]
    half_height = 0.5 * thick * (abs(rot[2, 1]) + abs(rot[2, 2])) + 5.0 * abs(rot[2, 0])
    position_b = np.array([0.1, 0.2, 1 + half_height - press])
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [10, thick, thick], position_b, q)
    assert_finite(c)
    assert c.colliding[0]
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-9)
    assert c.depth[0] == pytest.approx(press, rel=1e-6)
    assert c.contact_type[0] == "face-face"
    expected = rule_point([2.0, 2, 2], [10.0, thick, thick], position_b, q)
    np.testing.assert_allclose(c.point[0], expected, rtol=0, atol=COP_TOL_REL * 10.0)
    shallow = press - thick * np.sin(roll)
    profile = (press**2 + press * shallow + shallow**2) / (3 * (press + shallow))
    # The side face sliver is press x roll wide next to a face `thick` wide: it moves the
    # offset by less than press x (press roll / thick); the floor by tau / 2 at most.
    sliver = press * press * roll / thick + 0.5 * PRESSURE_FLOOR_REL * 6.0
    assert c.point[0, 2] == pytest.approx(1 - profile, abs=sliver)


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
