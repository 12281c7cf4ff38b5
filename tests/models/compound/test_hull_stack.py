"""Hull tables: rows of different part pairs in one convex call answer exactly as each pair's
own call, and a table holds each hull's own entries (nothing padded)."""
import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.convex_contact import convex_contacts, stacked_contacts
from impactnet.models.compound.hull import box_hull, convex_hull, hull_of
from impactnet.models.compound.hull_stack import size_classes, stack_hulls
from impactnet.models.geometry.rotations import quaternion_to_matrix, random_quaternions


def _hulls():
    """Hulls of different counts: a box, a detail-2 ring piece, twistlock heads of 8 and 32
    sides, and a wedge-like chamfer."""
    container = cb.container("40ft", detail=2)
    ring = next(p for p in container if "/ring_" in p.name)
    heads = [next(p for p in cb.spreader("40ft", sides=s) if p.name.startswith("head"))
             for s in (8, 32)]
    chamfer = convex_hull(np.array([[0, 0, 0], [0.2, 0, 0], [0, 0.3, 0], [0.2, 0.3, 0],
                                    [0, 0, 0.1], [0, 0.3, 0.1]], float))
    return (box_hull((0.2, 0.15, 0.1)), hull_of(ring), *(hull_of(h) for h in heads), chamfer)


def _centred(hull):
    """Body poses that put the hull's centre at the origin: the parts meet near it."""
    return hull.vertices.mean(axis=0)


def test_rows_of_mixed_part_pairs_answer_bit_for_bit_as_each_pair_alone():
    rng = np.random.default_rng(5)
    hulls = _hulls()
    n = 400
    ia, ib = rng.integers(0, len(hulls), n), rng.integers(0, len(hulls), n)
    rot_a = quaternion_to_matrix(random_quaternions(n, rng))
    rot_b = quaternion_to_matrix(random_quaternions(n, rng))
    centre_a = np.array([_centred(h) for h in hulls])[ia]
    centre_b = np.array([_centred(h) for h in hulls])[ib]
    pos_a = rng.normal(size=(n, 3)) * 10.0
    pos_b = (pos_a - np.einsum("nij,nj->ni", rot_b, centre_b)
             + np.einsum("nij,nj->ni", rot_a, centre_a) + rng.uniform(-0.08, 0.08, (n, 3)))
    stack = stack_hulls(hulls)
    got = stacked_contacts(stack, ia, stack, ib, pos_a, rot_a, pos_b, rot_b).arrays()
    assert 0.2 * n < got["colliding"].sum() < n  # touching and apart rows both
    for a in range(len(hulls)):
        for b in range(len(hulls)):
            rows = np.flatnonzero((ia == a) & (ib == b))
            if not len(rows):
                continue
            alone = convex_contacts(hulls[a], hulls[b], pos_a[rows], rot_a[rows], pos_b[rows],
                                    rot_b[rows]).arrays()
            for name, column in alone.items():
                np.testing.assert_array_equal(got[name][rows], column, err_msg=name)


def test_a_table_holds_each_hulls_own_entries_and_nothing_padded():
    hulls = _hulls()
    table = stack_hulls(hulls)
    assert table is stack_hulls(list(hulls))  # cached by the hulls' identities
    a = table.arrays
    assert len(a.vertices) == sum(len(h.vertices) for h in hulls)  # no padding at all
    assert len(a.edges) == sum(h.n_edges for h in hulls)
    for k, hull in enumerate(hulls):
        v, f, e = (slice(start[k], start[k + 1])
                   for start in (a.vertex_start, a.face_start, a.edge_start))
        np.testing.assert_array_equal(a.vertices[v], hull.vertices)
        np.testing.assert_array_equal(a.face_normals[f], hull.face_normals)
        np.testing.assert_array_equal(a.edges[e], hull.edges)
        np.testing.assert_array_equal(a.edge_faces[e], hull.edge_faces)
        assert table.n_faces[k] == hull.n_faces and table.n_edges[k] == hull.n_edges
        for face in range(hull.n_faces):
            loop = slice(a.loop_start[f.start + face], a.loop_start[f.start + face + 1])
            count = hull.face_counts[face]
            np.testing.assert_array_equal(a.loop_vertex[loop], hull.face_loops[face, :count])
            np.testing.assert_array_equal(a.side_planes[loop], hull.side_planes[face, :count])
        np.testing.assert_array_equal(a.centre[k], hull.vertices.mean(axis=0))
        # the Gauss-map tree lists every edge once; the face order reaches every face
        nodes = slice(a.node_start[k], a.node_start[k + 1])
        root_first, root_count = a.node_first[nodes][0], a.node_count[nodes][0]
        assert sorted(a.tree_edge[root_first:root_first + root_count]) == list(range(hull.n_edges))
        assert sorted(a.face_order[f]) == list(range(hull.n_faces))
    for array in a:
        assert not array.flags.writeable


def test_a_spreader_shares_one_table_in_which_small_parts_stay_small():
    """The size classes kept padding cheap; a flat table pads nothing, so one table holds a
    spreader's frame, shafts and 128-sided heads, each with its own counts."""
    parts = cb.spreader("40ft", sides=128)
    hulls = tuple(hull_of(p) for p in parts)
    classes = size_classes(hulls)
    assert classes is size_classes(hulls)
    assert size_classes(hulls, cached=False) is not classes  # a request's body: not cached
    table = classes.table
    assert len(classes.stacks) == 1 and (classes.klass == 0).all()
    edges = np.diff(table.arrays.edge_start)
    frame = [k for k, p in enumerate(parts) if not p.name.startswith("head")]
    heads = [k for k, p in enumerate(parts) if p.name.startswith("head")]
    assert (edges[frame] == 12).all() and (edges[heads] == 384).all()
    for k, hull in enumerate(hulls):
        assert classes.stacks[classes.klass[k]].hulls[classes.slot[k]] is hull
