"""The closest region's centroid in analytic cases, the touching and overlapping answers, frame
invariance, the row function called from another kernel, and the entry's inputs."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull, HalfspaceIntersection

from impactnet.models import compiled
from impactnet.models.distance import kernels
from impactnet.models.distance.query import PolytopePair, polytope_gaps
from impactnet.models.geometry.rotations import matrix_to_quaternion
from tests.models.distance.scenarios import box_corners, rotations

#: Analytic answers agree within this (m): rounding, and the region slack (1e-9 x scale).
ANALYTIC_TOL = 1e-8


def about(axis: int, angle: float) -> np.ndarray:
    """The rotation (3, 3) by ``angle`` (rad) about body axis ``axis``."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _one(vertices_a, vertices_b, position_b, rotation_b, position_a=(0, 0, 0),
         rotation_a=np.eye(3)):
    g = polytope_gaps(vertices_a, vertices_b, np.asarray(position_a, float), rotation_a,
                      np.asarray(position_b, float), rotation_b)
    return {k: v[0] for k, v in vars(g).items()}


def _rectangle_halfspaces(half, rotation2, centre2):
    """Half-planes ``A x + b <= 0`` (4, 3) of a rectangle of half sizes ``half`` (2,), turned
    by ``rotation2`` (2, 2) about ``centre2`` (2,)."""
    normals = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]) @ rotation2.T
    offsets = np.array([half[0], half[0], half[1], half[1]]) + normals @ centre2
    return np.column_stack([normals, -offsets])


def _polygon_centroid(halfspaces, inside) -> np.ndarray:
    """The area centroid of the intersection of half-planes (SciPy, independent of the
    kernel's clipping)."""
    corners = HalfspaceIntersection(halfspaces, inside).intersections
    ring = corners[ConvexHull(corners).vertices]
    cross = ring[:, 0] * np.roll(ring[:, 1], -1) - ring[:, 1] * np.roll(ring[:, 0], -1)
    return ((ring + np.roll(ring, -1, axis=0)) * cross[:, None]).sum(0) / (3.0 * cross.sum())


@pytest.mark.parametrize("gap", [0.7, 1e-3, 1e-9, 0.0])
def test_a_box_over_a_larger_box_answers_the_overlap_rectangles_centroid(gap):
    a, b = box_corners([4.0, 3.0, 2.0]), box_corners([2.0, 1.0, 1.0])
    got = _one(a, b, [1.7, 1.2, 1.5 + gap], np.eye(3))
    # footprints [-2, 2] x [-1.5, 1.5] and [0.7, 2.7] x [0.7, 1.7]: overlap [0.7, 2] x [0.7, 1.5]
    assert got["distance"] == pytest.approx(gap, abs=1e-12)
    assert got["colliding"] == (gap == 0.0)
    np.testing.assert_allclose(got["point"], [1.35, 1.1, 1.0 + 0.5 * gap], atol=ANALYTIC_TOL)
    np.testing.assert_allclose(got["point_a"], [1.35, 1.1, 1.0], atol=ANALYTIC_TOL)
    np.testing.assert_allclose(got["point_b"], [1.35, 1.1, 1.0 + gap], atol=ANALYTIC_TOL)
    np.testing.assert_allclose(got["direction"], [0.0, 0.0, 1.0 if gap else 0.0], atol=1e-12)


@pytest.mark.parametrize("angle,offset", [(0.3, (0.4, -0.2)), (np.pi / 4, (1.1, 0.9)),
                                          (1.2, (-1.6, 0.5)), (2.9, (0.0, 0.0))])
def test_a_box_turned_about_the_vertical_answers_the_intersection_polygons_centroid(
        angle, offset):
    a, b = box_corners([4.0, 3.0, 2.0]), box_corners([2.5, 1.2, 0.6])
    got = _one(a, b, [offset[0], offset[1], 1.3 + 0.25], about(2, angle))
    turn = about(2, angle)[:2, :2]
    halfspaces = np.concatenate([_rectangle_halfspaces([2.0, 1.5], np.eye(2), np.zeros(2)),
                                 _rectangle_halfspaces([1.25, 0.6], turn, np.array(offset))])
    expected = _polygon_centroid(halfspaces, np.array(offset))  # B's centre: over A's face
    assert got["distance"] == pytest.approx(0.25, abs=1e-12)
    np.testing.assert_allclose(got["point"], [*expected, 1.125], atol=ANALYTIC_TOL)


def test_parallel_edges_answer_the_middle_of_their_overlap():
    a, b = box_corners([1.0, 1.0, 1.0]), box_corners([2.0, 1.0, 1.0])
    ridge = np.sqrt(0.5)  # a unit cube's edge over its centre, turned 45 deg about x
    got = _one(a, b, [1.2, 0.0, 2.0 * ridge + 0.3], about(0, np.pi / 4),
               rotation_a=about(0, np.pi / 4))
    # A's ridge x in [-0.5, 0.5], B's lower ridge x in [0.2, 2.2]: overlap [0.2, 0.5]
    assert got["distance"] == pytest.approx(0.3, abs=1e-12)
    np.testing.assert_allclose(got["point"], [0.35, 0.0, ridge + 0.15], atol=ANALYTIC_TOL)


def test_an_edge_over_a_face_answers_the_middle_of_the_edge_over_the_face():
    a, b = box_corners([4.0, 4.0, 1.0]), box_corners([1.0, 1.0, 1.0])
    got = _one(a, b, [2.0, -0.7, 0.5 + np.sqrt(0.5) + 0.05], about(0, np.pi / 4))
    # B's lower edge x in [1.5, 2.5] over A's top face x in [-2, 2]
    np.testing.assert_allclose(got["point"], [1.75, -0.7, 0.525], atol=ANALYTIC_TOL)
    assert got["distance"] == pytest.approx(0.05, abs=1e-12)


def test_overlapping_bodies_are_colliding_at_a_point_of_both():
    a, b = box_corners([2.0, 2.0, 2.0]), box_corners([1.0, 1.0, 1.0])
    got = _one(a, b, [0.8, 0.3, 1.1], rotations(np.random.default_rng(5), 1)[0])
    assert got["colliding"] and got["distance"] == 0.0
    np.testing.assert_array_equal(got["direction"], 0.0)
    assert (np.abs(got["point"]) <= 1.0 + 1e-12).all()


def test_far_from_the_origin_the_answer_is_the_one_at_it():
    rng = np.random.default_rng(6)
    a, b = box_corners([2.0, 0.4, 0.3]), box_corners([0.5, 1.5, 0.2])
    shift, turn = np.array([1e4, -3e4, 2e4]), rotations(rng, 1)[0]
    ra, rb = rotations(rng, 20), rotations(rng, 20)
    pb = rng.uniform(-2.0, 2.0, (20, 3))
    near = polytope_gaps(a, b, np.zeros(3), ra, pb, rb)
    far = polytope_gaps(a, b, shift, turn @ ra, shift + pb @ turn.T, turn @ rb)
    np.testing.assert_allclose(far.distance, near.distance, atol=1e-10)
    np.testing.assert_allclose((far.point - shift) @ turn, near.point, atol=1e-10)
    np.testing.assert_allclose(far.direction @ turn, near.direction, atol=1e-9)


@compiled.jit
def _caller(vertices, vertex_start, hull_size, t, r, distance, point_a, point_b, point,
            direction):
    work = np.empty(kernels.scratch_slots(8))
    for i in range(t.shape[0]):
        kernels.gap_row(vertices, vertex_start, hull_size, 1, 0, t[i], r[i], work, i, distance,
                        point_a, point_b, point, direction)


def test_another_kernel_calls_the_row_function_on_the_flat_tables():
    rng = np.random.default_rng(7)
    a, b = box_corners([1.0, 2.0, 0.5]), box_corners([0.3, 0.3, 0.3])
    tables = PolytopePair(b, a).tables  # hull 1 is ``a`` here: the caller asks (1, 0)
    t, r = rng.uniform(-3.0, 3.0, (50, 3)), rotations(rng, 50)
    outs = [np.empty(50)] + [np.empty((50, 3)) for _ in range(4)]
    _caller(tables.vertices, tables.vertex_start, tables.hull_size, t, r, *outs)
    expected = polytope_gaps(a, b, np.zeros(3), np.eye(3), t, r)
    for got, name in zip(outs, ("distance", "point_a", "point_b", "point", "direction")):
        np.testing.assert_allclose(got, getattr(expected, name), atol=1e-12)


def test_quaternions_matrices_and_batches_give_one_answer():
    rng = np.random.default_rng(8)
    a, b = box_corners([1.0, 2.0, 0.5]), box_corners([0.3, 0.3, 0.3])
    ra, rb = rotations(rng, 300), rotations(rng, 300)
    pa, pb = rng.uniform(-1, 1, (300, 3)), rng.uniform(-3, 3, (300, 3))
    batch = polytope_gaps(a, b, pa, ra, pb, rb)  # parallel kernel
    quats = polytope_gaps(a, b, pa, matrix_to_quaternion(ra), pb, matrix_to_quaternion(rb))
    one = polytope_gaps(a, b, pa[7], ra[7], pb[7], rb[7])  # serial kernel
    np.testing.assert_allclose(quats.distance, batch.distance, atol=1e-12)
    assert one.distance[0] == batch.distance[7]
    np.testing.assert_array_equal(one.point[0], batch.point[7])
    with pytest.raises(ValueError):
        polytope_gaps(a, b, pa[:5], ra[:5], pb[:6], rb[:6])
    with pytest.raises(ValueError):
        polytope_gaps(a, b, np.zeros(2), np.eye(3), np.zeros(3), np.eye(3))


def test_the_kernels_register_a_warm_up():
    from impactnet.models.distance import query

    assert query.warm_up in compiled._WARM_UPS
    query.warm_up()
