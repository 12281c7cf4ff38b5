"""Hull tables: the box's own feature ids, generated shapes, stable ids, refusals."""
import numpy as np
import pytest

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.hull import box_hull, convex_hull
from impactnet.models.compound.parts import PartError
from impactnet.models.geometry import box_features as bf


def _head(sides):
    return next(p for p in cb.spreader("40ft", sides=sides) if p.name.startswith("head"))


def test_a_box_hull_keeps_the_box_feature_ids():
    hull = box_hull((2.0, 1.0, 0.5), (1.0, 0.0, 0.0))
    np.testing.assert_array_equal(hull.face_normals, bf.face_normals())
    np.testing.assert_array_equal(hull.edges, np.sort(bf.EDGE_VERTICES - bf.VERTEX_BASE, axis=1))
    assert hull.edge_id(0) == bf.EDGE_BASE and hull.vertex_id(0) == bf.VERTEX_BASE
    np.testing.assert_allclose(hull.face_offsets, [2.0, 0.0, 0.5, 0.5, 0.25, 0.25])


@pytest.mark.parametrize("sides", [8, 32, 256])
def test_a_twistlock_head_is_a_frustum_of_two_stadiums_and_side_quads(sides):
    hull = convex_hull(_head(sides).vertices())
    assert (len(hull.vertices), hull.n_faces, hull.n_edges) == (2 * sides, sides + 2, 3 * sides)
    assert sorted(hull.face_counts.tolist())[-2:] == [sides, sides]
    # Euler: V - E + F = 2, and every face loop is counter-clockwise seen from outside
    assert len(hull.vertices) - hull.n_edges + hull.n_faces == 2
    for f in range(hull.n_faces):
        loop = hull.vertices[hull.face_loops[f, :hull.face_counts[f]]]
        area = np.cross(loop - loop[0], np.roll(loop, -1, axis=0) - loop[0]).sum(axis=0)
        assert area @ hull.face_normals[f] > 0


def test_the_same_points_give_the_same_feature_ids():
    first, second = convex_hull(_head(32).vertices()), convex_hull(_head(32).vertices())
    for name in ("vertices", "face_loops", "edges", "triangles"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))


def test_flat_points_have_no_hull():
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    with pytest.raises(PartError, match="no convex hull"):
        convex_hull(flat, "plate")
