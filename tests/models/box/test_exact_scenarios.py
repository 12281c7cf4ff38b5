"""Exact solver: scenarios whose answers are known by hand.

Points follow docs/design.md's centre of pressure: the depth-weighted centroid of the footprint,
half the local depth below the reference face, i.e. the centroid of the solid between the
face and the incident box. A vertex pressed into a face cuts off a tetrahedron (the point is
the mean of its four corners: d / 4 below the face), an edge lying on a face a wedge (the
tent profile: d / 3 below), a flat face a slab (the overlap rectangle's centroid, d / 2).
"""
import numpy as np
import pytest

from impactnet.models.box.exact import InvalidBoxError, box_box
from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import (
    InvalidRotationError,
    euler_to_matrix,
    euler_to_quaternion,
    matrix_to_quaternion,
)
from tests.models.helpers import assert_finite

#: Absolute tolerance (metres) for hand-computed answers: a few ulps of the metre scale.
HAND_TOL = 1e-12


def floor_tol(scale):
    """Tolerance (metres) of a hand-computed point of a vertex or edge contact: the solver's
    pressure floor tau = PRESSURE_FLOOR_REL x ``scale`` (the sum of both largest half-extents)
    lifts such a point by tau / 4 (tetrahedron) or tau / 6 (tent) towards the face; flat
    contacts have a uniform depth and are not moved."""
    return HAND_TOL + 0.5 * PRESSURE_FLOOR_REL * scale
IDENTITY = [1.0, 0.0, 0.0, 0.0]
SQRT2, SQRT3 = np.sqrt(2.0), np.sqrt(3.0)


def vertex_down_quaternion():
    """Rotation taking B's (+,+,+) vertex direction to -z (the vertex points down)."""
    down = -np.ones(3) / SQRT3
    z = np.array([0.0, 0.0, -1.0])
    axis = np.cross(down, z)
    angle = np.arccos(np.clip(down @ z, -1, 1))
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    # Rodrigues: rotates the (-,-,-) diagonal onto -z, i.e. (+,+,+) onto +z; flip with pi about x.
    rot = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    flip = np.diag([1.0, -1.0, -1.0])
    return matrix_to_quaternion(flip @ rot)[0]


def test_resting_face_face_point_is_centre_of_overlap():
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [1, 1, 1], [0.3, 0.2, 1.49], IDENTITY)
    assert c.colliding[0]
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=HAND_TOL)
    assert c.depth[0] == pytest.approx(0.01, abs=HAND_TOL)
    np.testing.assert_allclose(c.point[0], [0.3, 0.2, 0.995], atol=HAND_TOL)
    assert c.contact_type[0] == "face-face"
    assert (c.feature_a[0], c.feature_b[0]) == (bf.face_id(2, False), bf.face_id(2, True))
    assert c.manifold_count[0] == 4
    assert_finite(c)


def test_partial_overlap_of_a_large_box_puts_the_point_at_the_overlap_centre():
    # B (4 x 4 x 1) overhangs A's top face (2 x 2) on +x: overlap x in [0.5, 1], y in [-1, 1].
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [4, 4, 1], [2.5, 0.0, 1.49], IDENTITY)
    np.testing.assert_allclose(c.point[0], [0.75, 0.0, 0.995], atol=HAND_TOL)
    assert c.contact_type[0] == "face-face"


def test_vertex_on_face_point_is_a_quarter_of_the_depth_below_the_vertex():
    """B's body diagonal is vertical: the cut-off corner is a tetrahedron whose base (an
    equilateral triangle in the face) is centred under the vertex, so the point is the
    vertex's projection, d / 4 below the face. The manifold is the vertex on the
    mid-surface (d / 2 below), as before."""
    q = vertex_down_quaternion()
    centre = np.array([0.1, 0.2, 1.0 + SQRT3 - 0.01])
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [2, 2, 2], centre, q)
    assert c.contact_type[0] == "face-vertex"
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-12)
    assert c.depth[0] == pytest.approx(0.01, abs=1e-12)
    np.testing.assert_allclose(c.point[0], [0.1, 0.2, 1.0 - 0.01 / 4], atol=floor_tol(2.0))
    assert bf.feature_kind(c.feature_b[0]) == "vertex"
    assert c.manifold_count[0] == 1
    np.testing.assert_allclose(c.manifold_points[0, 0], [0.1, 0.2, 0.995], atol=HAND_TOL)


def test_vertex_of_a_on_face_of_b_mirrors_the_labels():
    q = vertex_down_quaternion()
    centre = np.array([0.1, 0.2, 1.0 + SQRT3 - 0.01])
    c = box_box([2, 2, 2], centre, q, [2, 2, 2], [0, 0, 0], IDENTITY)
    assert c.contact_type[0] == "vertex-face"
    np.testing.assert_allclose(c.normal[0], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(c.point[0], [0.1, 0.2, 1.0 - 0.01 / 4], atol=floor_tol(2.0))


def test_oblique_vertex_point_is_the_centroid_of_the_cut_off_tetrahedron():
    """A cube in a general orientation presses its lowest vertex v 10 mm into A's face. Its
    three edges leave v upwards with slopes e_k . z and cross the face at a_k = v + (d / e_k .
    z) e_k: the region is the tetrahedron (v, a_1, a_2, a_3), whose centroid, the mean of its
    corners, is the point (tangentially off the vertex towards the shallow edges)."""
    depth = 0.01
    rot = euler_to_matrix([0.6, -0.5, 0.2])[0]
    lowest = -np.sign(rot[2])  # the vertex's signs along B's axes: every axis points down
    centre = np.array([0.1, 0.2, 1.0 - depth + np.abs(rot[2]).sum()])
    vertex = centre + rot @ lowest  # half-extents 1
    edges = -lowest * rot  # columns: unit edge directions from the vertex, upwards
    crossings = vertex + (depth / edges[2])[:, None] * edges.T  # (3 edges, 3)
    expected = (vertex + crossings.sum(axis=0)) / 4.0
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [2, 2, 2], centre,
                matrix_to_quaternion(rot)[0])
    assert c.contact_type[0] == "face-vertex"
    assert c.depth[0] == pytest.approx(depth, abs=HAND_TOL)
    assert expected[2] == pytest.approx(1.0 - depth / 4, abs=HAND_TOL)
    np.testing.assert_allclose(c.point[0], expected, atol=floor_tol(2.0))
    assert np.linalg.norm(expected[:2] - vertex[:2]) > 1e3 * floor_tol(2.0)  # not the vertex


def test_edges_crossing_at_90_degrees_give_edge_edge():
    qa = euler_to_quaternion([0, np.pi / 4, 0])[0]  # A's ridge along y at z = sqrt2
    qb = euler_to_quaternion([np.pi / 4, 0, 0])[0]  # B's lower ridge along x
    c = box_box([2, 2, 2], [0, 0, 0], qa, [2, 2, 2], [0, 0, 2 * SQRT2 - 0.02], qb)
    assert c.contact_type[0] == "edge-edge"
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-12)
    assert c.depth[0] == pytest.approx(0.02, abs=1e-12)
    np.testing.assert_allclose(c.point[0], [0, 0, SQRT2 - 0.01], atol=1e-12)
    assert bf.feature_kind(c.feature_a[0]) == "edge" and bf.feature_kind(c.feature_b[0]) == "edge"


@pytest.mark.parametrize("yaw", [0.0, np.pi / 4])
def test_edge_lying_on_a_face_at_45_degrees_gives_face_edge(yaw):
    """B (1 x 2 x 2) rolled 45 degrees about its x axis rests on its lowest x edge, which is
    then turned by `yaw` in the plane of A's top face. The depth profile is a tent (d at the
    edge, 0 at 2 d across) along the whole edge: the point is the edge's middle, d / 3 below
    the face (the depth-weighted segment centroid on the mid-surface)."""
    qb = euler_to_quaternion([np.pi / 4, 0, yaw])[0]
    c = box_box([3, 3, 2], [0, 0, 0], IDENTITY, [1, 2, 2], [0.2, -0.1, 1 + SQRT2 - 0.01], qb)
    assert c.contact_type[0] == "face-edge"
    assert c.feature_b[0] == bf.edge_id(0, True, True)
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-12)
    assert c.depth[0] == pytest.approx(0.01, abs=1e-12)
    np.testing.assert_allclose(c.point[0], [0.2, -0.1, 1.0 - 0.01 / 3], atol=floor_tol(2.5))
    assert c.manifold_count[0] == 2
    np.testing.assert_allclose(c.manifold_points[0, :2, 2], 0.995, atol=HAND_TOL)


def test_box_inside_another_pushes_out_through_the_nearest_face():
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [0.5, 0.5, 0.5], [0, 0, 0.2], IDENTITY)
    assert c.colliding[0]
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=HAND_TOL)
    assert c.depth[0] == pytest.approx(1.05, abs=HAND_TOL)
    np.testing.assert_allclose(c.point[0], [0, 0, 0.475], atol=HAND_TOL)


def test_concentric_boxes_resolve_the_tie_to_the_lowest_axis():
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [2, 2, 2], [0, 0, 0], IDENTITY)
    assert c.axis[0] == 0
    np.testing.assert_allclose(c.normal[0], [1, 0, 0])
    assert c.depth[0] == pytest.approx(2.0)
    assert_finite(c)


def test_exactly_touching_is_colliding_with_zero_depth():
    centres = [[0.5, 0.25, 2.0], [0.5, 0.25, 2.0 + 1e-9]]
    c = box_box([2, 2, 2], [0, 0, 0], IDENTITY, [2, 2, 2], centres, IDENTITY)
    assert c.colliding.tolist() == [True, False]
    assert c.depth.tolist() == [0.0, 0.0]
    np.testing.assert_allclose(c.point[0], [0.25, 0.125, 1.0], atol=HAND_TOL)
    assert c.contact_type.tolist() == ["face-face", "none"]
    assert c.feature_a[1] == c.feature_b[1] == bf.NO_FEATURE
    assert_finite(c)


@pytest.mark.parametrize("size_a,size_b", [
    ([12.192, 2.438, 2.591], [12.192, 2.438, 2.591]),  # 40 ft on 40 ft
    ([4.0, 4.0, 1.0], [2.0, 2.0, 0.01]),  # a thin plate on a block (MuJoCo's thin-box case)
])
def test_resting_stack_at_0056_mm_has_no_phantom_deep_contact(size_a, size_b):
    overlap = 0.056e-3
    z = 0.5 * (size_a[2] + size_b[2]) - overlap
    c = box_box(size_a, [10.0, -3.0, 1.0], IDENTITY, size_b, [10.0, -3.0, 1.0 + z], IDENTITY)
    assert c.depth[0] == pytest.approx(overlap, rel=1e-9)
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=HAND_TOL)
    top = 1.0 + 0.5 * size_a[2]
    np.testing.assert_allclose(c.point[0], [10.0, -3.0, top - overlap / 2], atol=1e-9)
    assert c.contact_type[0] == "face-face"


def test_separated_rows_carry_no_nan_and_no_features():
    c = box_box([1, 1, 1], [0, 0, 0], IDENTITY, [1, 1, 1], [[3, 0, 0], [0, -5, 0]], IDENTITY)
    assert not c.colliding.any()
    np.testing.assert_allclose(c.normal, [[1, 0, 0], [0, -1, 0]])
    assert (c.manifold_count == 0).all() and (c.contact_type_code == 0).all()
    assert_finite(c)


def test_batch_row_equals_single_call():
    rng = np.random.default_rng(7)
    pos = rng.normal(size=(50, 3))
    quat = rng.normal(size=(50, 4))
    batch = box_box([2, 1, 1.5], [0, 0, 0], IDENTITY, [1, 1, 1], pos, quat)
    for i in range(50):
        one = box_box([2, 1, 1.5], [0, 0, 0], IDENTITY, [1, 1, 1], pos[i], quat[i])
        for name, value in one.arrays().items():
            expected = getattr(batch, name)[i]
            if value.dtype.kind == "f":
                np.testing.assert_allclose(value[0], expected, atol=1e-12, err_msg=name)
            else:
                np.testing.assert_array_equal(value[0], expected, err_msg=name)


@pytest.mark.parametrize("kwargs,field", [
    ({"size_a": [0, 1, 1]}, "size_a"),
    ({"size_b": [1, -1, 1]}, "size_b"),
    ({"position_a": [np.nan, 0, 0]}, "position_a"),
    ({"position_b": [np.inf, 0, 0]}, "position_b"),
    ({"size_a": [1, 1]}, "size_a"),
])
def test_invalid_box_inputs_name_the_field(kwargs, field):
    args = dict(size_a=[1, 1, 1], position_a=[0, 0, 0], quaternion_a=IDENTITY,
                size_b=[1, 1, 1], position_b=[0, 0, 0.9], quaternion_b=IDENTITY)
    args.update(kwargs)
    with pytest.raises(InvalidBoxError) as info:
        box_box(**args)
    assert info.value.field == field


def test_zero_quaternion_is_rejected():
    with pytest.raises(InvalidRotationError):
        box_box([1, 1, 1], [0, 0, 0], [0, 0, 0, 0], [1, 1, 1], [0, 0, 0.9], IDENTITY)


def test_ragged_batch_is_rejected():
    with pytest.raises(InvalidBoxError):
        box_box([1, 1, 1], np.zeros((3, 3)), IDENTITY, [1, 1, 1], np.zeros((4, 3)), IDENTITY)


@pytest.mark.parametrize("size_a,size_b", [
    ((2.0, 2.0, 2.0), (2.0, 2.0, 2.0)), ((12.19, 2.44, 2.59), (6.06, 2.44, 2.59)),
    ((12.0, 2.35, 0.8), (12.19, 2.44, 2.59)), ((4.0, 4.0, 0.2), (0.05, 0.05, 3.0))])
def test_single_pairs_equal_batch_rows_bit_for_bit_on_first_contacts(size_a, size_b):
    """N = 1 (the scalar path) and the batch give the same bits on seeded first contacts,
    face and edge-edge rows alike: the tie rule's early exit and the centre of pressure
    included."""
    from impactnet.models.geometry.poses import first_contact_poses

    poses = first_contact_poses(400, np.asarray(size_a), np.asarray(size_b),
                                np.random.default_rng(11))
    keys = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
    batch = box_box(*(poses[k] for k in keys))
    for i in range(400):
        one = box_box(*(poses[k][i] for k in keys))
        for name in ("point", "normal", "depth", "contact_type_code", "feature_a", "feature_b"):
            assert np.array_equal(getattr(one, name)[0], getattr(batch, name)[i]), (name, i)
