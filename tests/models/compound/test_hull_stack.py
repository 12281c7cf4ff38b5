"""Hull stacks: rows of different part pairs in one convex call answer exactly as each pair's
own call (the padding never changes a bit), and a body's hulls split into size classes."""
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


def test_padding_keeps_each_hulls_own_counts_and_marks_the_padded_entries():
    hulls = _hulls()
    stack = stack_hulls(hulls)
    assert stack is stack_hulls(list(hulls))  # cached by the hulls' identities
    width = stack.width
    assert width["V"] == max(len(h.vertices) for h in hulls)
    for k, hull in enumerate(hulls):
        assert stack.n_faces[k] == hull.n_faces and stack.n_edges[k] == hull.n_edges
        assert stack.edge_valid[k].sum() == hull.n_edges
        assert stack.triangle_valid[k].sum() == len(hull.triangles)
        assert not stack.vertex_faces[k, :, hull.n_faces:].any()
        np.testing.assert_array_equal(stack.vertices[k, len(hull.vertices):],
                                      np.repeat(hull.vertices[:1], width["V"] -
                                                len(hull.vertices), axis=0))
        np.testing.assert_array_equal(stack.centre[k], hull.vertices.mean(axis=0))


def test_a_spreader_splits_into_size_classes_that_keep_small_parts_small():
    parts = cb.spreader("40ft", sides=128)
    hulls = tuple(hull_of(p) for p in parts)
    classes = size_classes(hulls)
    assert classes is size_classes(hulls)
    frame = [k for k, p in enumerate(parts) if not p.name.startswith("head")]
    heads = [k for k, p in enumerate(parts) if p.name.startswith("head")]
    assert len(set(classes.klass[frame]) & set(classes.klass[heads])) == 0
    small = classes.stacks[classes.klass[frame[0]]]
    assert small.width["E"] < 50 and classes.stacks[classes.klass[heads[0]]].width["E"] >= 384
    for k, hull in enumerate(hulls):
        assert classes.stacks[classes.klass[k]].hulls[classes.slot[k]] is hull
