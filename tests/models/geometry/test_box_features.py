"""Box feature ids, geometry tables and symmetries, checked against brute force."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from impactnet.models.geometry import box_features as bf

SIZES = [(1.0, 1.0, 1.0), (1.0, 1.0, 2.0), (1.0, 2.0, 3.0), (12.192, 2.438, 2.591)]
CUBE = np.ones(3)


def all_centres(size):
    """Centres (26, 3) of every feature id of a box, from the public geometry tables."""
    return np.concatenate([bf.face_centers(size), bf.edge_centers(size),
                           bf.vertex_positions(size)])


def feature_geometry(size):
    """Per id: (centre, direction or None); direction = face normal or edge direction."""
    centres = all_centres(size)
    dirs = [*bf.face_normals(), *bf.edge_directions(), *([None] * bf.N_VERTICES)]
    return centres, dirs


def brute_force_permutation(S, size):
    """Image of each feature under x -> S x, found by matching transformed geometry."""
    centres, dirs = feature_geometry(size)
    kinds = bf.feature_kind(np.arange(bf.N_FEATURES))
    perm = np.full(bf.N_FEATURES, -999)
    for f in range(bf.N_FEATURES):
        image_centre = S @ centres[f]
        match = [g for g in range(bf.N_FEATURES)
                 if kinds[g] == kinds[f] and np.allclose(centres[g], image_centre)]
        assert len(match) == 1
        g = match[0]
        if kinds[f] == "face":  # normals map exactly
            assert np.allclose(S @ dirs[f], dirs[g])
        elif kinds[f] == "edge":  # edge direction maps to +-the image's direction
            assert np.isclose(abs(np.dot(S @ dirs[f], dirs[g])), 1.0)
        perm[f] = g
    return perm


def vertex_set_maps_onto_itself(S, size):
    verts = bf.vertex_positions(size)
    image = verts @ np.asarray(S, dtype=float).T
    dist = np.linalg.norm(image[:, None] - verts[None], axis=-1)
    return np.all(dist.min(axis=1) < 1e-9) and len(set(dist.argmin(axis=1))) == 8


# --- ids -------------------------------------------------------------------------------------

def test_ids_are_a_bijection_onto_0_to_25():
    faces = [int(bf.face_id(a, n)) for a, n in itertools.product(range(3), (0, 1))]
    edges = [int(bf.edge_id(a, j, l)) for a, j, l in itertools.product(range(3), (0, 1), (0, 1))]
    verts = [int(bf.vertex_id(*n)) for n in itertools.product((0, 1), repeat=3)]
    ids = faces + edges + verts
    assert sorted(ids) == list(range(26))
    assert set(bf.feature_kind(faces)) == {"face"}
    assert set(bf.feature_kind(edges)) == {"edge"}
    assert set(bf.feature_kind(verts)) == {"vertex"}
    assert bf.feature_kind(-1) == "none"


def test_feature_names_are_readable_and_unique():
    assert bf.feature_name(0) == "face +x"
    assert bf.feature_name(5) == "face -z"
    assert bf.feature_name(int(bf.edge_id(0, False, True))) == "edge x(+y,-z)"
    assert bf.feature_name(int(bf.edge_id(1, True, False))) == "edge y(-x,+z)"
    assert bf.feature_name(int(bf.vertex_id(False, True, False))) == "vertex (+,-,+)"
    assert bf.feature_name(-1) == "none"
    assert isinstance(bf.feature_name(np.int64(3)), str)
    names = bf.feature_name(np.arange(-1, 26).reshape(3, 9))
    assert names.shape == (3, 9) and len(set(names.ravel())) == 27


@pytest.mark.parametrize("bad", [26, -2, 1.5, [0, 30]])
def test_invalid_ids_are_rejected(bad):
    with pytest.raises(ValueError):
        bf.feature_kind(bad)
    with pytest.raises(ValueError):
        bf.map_features(0, bad)


# --- geometry tables agree with the id encoding ---------------------------------------------

@pytest.mark.parametrize("size", SIZES)
def test_vertex_positions_carry_the_signs_encoded_in_their_ids(size):
    h = np.asarray(size) / 2
    for neg in itertools.product((False, True), repeat=3):
        v = int(bf.vertex_id(*neg)) - bf.VERTEX_BASE
        assert np.allclose(bf.vertex_positions(size)[v], np.where(neg, -h, h))


@pytest.mark.parametrize("size", SIZES)
def test_face_centres_and_normals_agree_with_face_id(size):
    h = np.asarray(size) / 2
    for axis, neg in itertools.product(range(3), (False, True)):
        f = int(bf.face_id(axis, neg))
        normal = np.zeros(3)
        normal[axis] = -1.0 if neg else 1.0
        assert np.array_equal(bf.face_normals()[f], normal)
        assert np.allclose(bf.face_centers(size)[f], normal * h)


@pytest.mark.parametrize("size", SIZES)
def test_edge_vertices_differ_only_along_the_edge_axis_and_centre_is_midpoint(size):
    verts, h = bf.vertex_positions(size), np.asarray(size) / 2
    for axis, nj, nl in itertools.product(range(3), (False, True), (False, True)):
        e = int(bf.edge_id(axis, nj, nl)) - bf.EDGE_BASE
        p0, p1 = verts[bf.EDGE_VERTICES[e] - bf.VERTEX_BASE]
        diff = p1 - p0
        assert np.count_nonzero(np.abs(diff) > 1e-12) == 1 and diff[axis] > 0
        assert np.allclose(bf.edge_centers(size)[e], (p0 + p1) / 2)
        assert np.isclose(bf.edge_lengths(size)[e], np.linalg.norm(diff))
        assert np.allclose(bf.edge_directions()[e], diff / np.linalg.norm(diff))
        j, l = [a for a in range(3) if a != axis]
        assert np.isclose(p0[j], -h[j] if nj else h[j])
        assert np.isclose(p0[l], -h[l] if nl else h[l])


@pytest.mark.parametrize("size", SIZES)
def test_face_vertices_lie_on_the_face_and_are_ccw_seen_from_outside(size):
    verts = bf.vertex_positions(size)
    for f in range(6):
        poly = verts[bf.FACE_VERTICES[f] - bf.VERTEX_BASE]
        normal, centre = bf.face_normals()[f], bf.face_centers(size)[f]
        assert len(set(bf.FACE_VERTICES[f])) == 4
        assert np.allclose((poly - centre) @ normal, 0.0)
        for k in range(4):  # every corner turns left about the outward normal
            a, b, c = poly[k], poly[(k + 1) % 4], poly[(k + 2) % 4]
            turn = np.cross(b - a, c - b)
            assert np.allclose(turn / np.linalg.norm(turn), normal)
        # the four are all vertices on that face's plane
        on_plane = np.flatnonzero(np.isclose((verts - centre) @ normal, 0.0)) + bf.VERTEX_BASE
        assert set(on_plane) == set(bf.FACE_VERTICES[f])


def test_adjacency_tables_agree_with_brute_force_incidence():
    for f in range(6):
        face_verts = set(bf.FACE_VERTICES[f])
        expected = {e + bf.EDGE_BASE for e in range(12) if set(bf.EDGE_VERTICES[e]) <= face_verts}
        assert set(bf.FACE_EDGES[f]) == expected
        for k in range(4):  # edge k joins vertices k and k+1
            ring = {bf.FACE_VERTICES[f, k], bf.FACE_VERTICES[f, (k + 1) % 4]}
            assert set(bf.EDGE_VERTICES[bf.FACE_EDGES[f, k] - bf.EDGE_BASE]) == ring
    for e in range(12):
        faces = {f for f in range(6) if e + bf.EDGE_BASE in bf.FACE_EDGES[f]}
        assert set(bf.EDGE_FACES[e]) == faces and len(faces) == 2
    for v in range(8):
        vid = v + bf.VERTEX_BASE
        faces = [f for f in range(6) if vid in bf.FACE_VERTICES[f]]
        edges = [e + bf.EDGE_BASE for e in range(12) if vid in bf.EDGE_VERTICES[e]]
        assert sorted(bf.VERTEX_FACES[v]) == faces and sorted(bf.VERTEX_EDGES[v]) == edges
        assert list(bf.FACE_AXIS[bf.VERTEX_FACES[v]]) == [0, 1, 2]
        assert list(bf.EDGE_AXIS[bf.VERTEX_EDGES[v] - bf.EDGE_BASE]) == [0, 1, 2]
    for table in (bf.FACE_VERTICES, bf.EDGE_VERTICES, bf.SIGNED_PERMUTATIONS,
                  bf.FEATURE_PERMUTATIONS):
        assert np.issubdtype(table.dtype, np.integer) and not table.flags.writeable


def test_geometry_broadcasts_over_batches_of_sizes():
    sizes = np.array(SIZES)
    assert bf.face_centers(sizes).shape == (4, 6, 3)
    assert bf.edge_centers(sizes).shape == (4, 12, 3)
    assert bf.edge_lengths(sizes).shape == (4, 12)
    assert bf.vertex_positions(sizes[None]).shape == (1, 4, 8, 3)
    for n, size in enumerate(SIZES):
        assert np.allclose(bf.vertex_positions(sizes)[n], bf.vertex_positions(size))
        assert np.allclose(bf.edge_lengths(sizes)[n], bf.edge_lengths(size))


# --- signed permutations and box symmetries -------------------------------------------------

def test_signed_permutations_are_the_48_distinct_orthogonal_sign_permutations():
    mats = bf.SIGNED_PERMUTATIONS
    assert mats.shape == (48, 3, 3) and np.array_equal(mats[0], np.eye(3))
    assert len({m.tobytes() for m in mats}) == 48
    assert set(np.unique(mats)) == {-1, 0, 1}
    assert np.allclose(mats @ mats.transpose(0, 2, 1), np.eye(3))
    dets = np.rint(np.linalg.det(mats))
    assert np.array_equal(dets, bf.SIGNED_PERMUTATION_DETS)
    assert (dets == 1).sum() == 24 and (dets == -1).sum() == 24
    for k, perm in enumerate(itertools.permutations(range(3))):  # index 8 k: unsigned perm k
        assert np.array_equal(mats[8 * k], np.eye(3)[list(perm)])
    for k in range(8):  # 0-7 are the pure sign flips, indexed like sign_flip_index
        assert np.array_equal(mats[k], np.diag(np.diag(mats[k])))
        assert bf.sign_flip_index(np.diag(mats[k])) == k


@pytest.mark.parametrize("k", range(48))
def test_every_signed_permutation_maps_the_cube_vertex_set_onto_itself(k):
    assert vertex_set_maps_onto_itself(bf.SIGNED_PERMUTATIONS[k], CUBE)


@pytest.mark.parametrize("size, snapped, count", [
    ((1, 1, 1), (1, 1, 1), 48), ((1, 1, 2), (1, 1, 2), 16), ((2, 1, 2), (2, 1, 2), 16),
    ((1, 2, 3), (1, 2, 3), 8), ((2, 2 + 1e-13, 3), (2, 2, 3), 16),  # equal within tolerance
    ((2, 2 * (1 + 1e-3), 3), (2, 2 * (1 + 1e-3), 3), 8),             # really different
])
def test_box_symmetries_count_and_match_brute_force(size, snapped, count):
    syms = bf.box_symmetries(size)
    assert syms.shape == (count, 3, 3)
    brute = [k for k in range(48) if vertex_set_maps_onto_itself(bf.SIGNED_PERMUTATIONS[k],
                                                                 snapped)]
    assert list(bf.box_symmetry_indices(size)) == brute
    assert np.array_equal(syms, bf.SIGNED_PERMUTATIONS[brute])


def test_box_symmetries_with_chained_near_equal_sizes_still_form_a_group():
    size = (1.0, 1.0 + 0.8e-6, 1.0 + 1.6e-6)  # a ~ b ~ c but |a - c| > tol
    syms = bf.box_symmetries(size)
    assert len(syms) == 48
    keys = {m.tobytes() for m in syms}
    assert all((a @ b).tobytes() in keys for a in syms for b in syms)


def test_box_symmetries_reject_bad_sizes():
    for bad in [(1, 1), (1, 0, 1), (1, np.nan, 1)]:
        with pytest.raises(ValueError):
            bf.box_symmetries(bad)


# --- feature permutations --------------------------------------------------------------------

@pytest.mark.parametrize("size", SIZES)
def test_feature_permutation_agrees_with_brute_force_on_transformed_geometry(size):
    for k in bf.box_symmetry_indices(size):
        S = bf.SIGNED_PERMUTATIONS[k]
        perm = bf.feature_permutation(S)
        assert np.array_equal(perm, brute_force_permutation(S, size))
        assert np.array_equal(perm, bf.FEATURE_PERMUTATIONS[k])
        assert sorted(perm) == list(range(26))
        assert np.array_equal(bf.feature_kind(perm), bf.feature_kind(np.arange(26)))


def test_feature_permutation_is_a_group_homomorphism_in_the_stated_order():
    mats, perms = bf.SIGNED_PERMUTATIONS, bf.FEATURE_PERMUTATIONS
    non_commuting = 0
    for i, j in itertools.product(range(48), repeat=2):
        composed = bf.feature_permutation(mats[i] @ mats[j])  # x -> S_i (S_j x)
        assert np.array_equal(composed, perms[i][perms[j]])
        non_commuting += not np.array_equal(composed, perms[j][perms[i]])
    assert non_commuting > 0  # so the order of composition was really tested


def test_feature_permutation_is_vectorised_over_matrices_and_indices():
    batch = bf.SIGNED_PERMUTATIONS.reshape(6, 8, 3, 3)
    assert np.array_equal(bf.feature_permutation(batch), bf.FEATURE_PERMUTATIONS.reshape(6, 8, 26))
    assert np.array_equal(bf.feature_permutation(np.arange(48)), bf.FEATURE_PERMUTATIONS)
    with pytest.raises(ValueError):
        bf.feature_permutation(np.eye(3) * 2)
    with pytest.raises(ValueError):
        bf.feature_permutation(48)


def test_map_features_keeps_none_and_accepts_indices_or_matrices():
    rng = np.random.default_rng(0)
    ks = rng.integers(0, 48, size=200)
    ids = rng.integers(-1, 26, size=200)
    by_index = bf.map_features(ks, ids)
    by_matrix = bf.map_features(bf.SIGNED_PERMUTATIONS[ks].astype(float), ids)
    assert np.array_equal(by_index, by_matrix)
    assert np.array_equal(by_index == -1, ids == -1)
    brute = [bf.FEATURE_PERMUTATIONS[k][i] if i >= 0 else -1 for k, i in zip(ks, ids)]
    assert np.array_equal(by_index, brute)
    inverse = bf.map_features(bf.SIGNED_PERMUTATIONS[ks].transpose(0, 2, 1), by_index)
    assert np.array_equal(inverse, ids)
    # one symmetry, many ids; and broadcasting of (n, 1) symmetries against (m,) ids
    assert np.array_equal(bf.map_features(5, np.arange(-1, 26)),
                          np.r_[-1, bf.FEATURE_PERMUTATIONS[5]])
    assert bf.map_features(np.arange(4)[:, None], np.arange(7)).shape == (4, 7)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 47), st.integers(0, 47), st.lists(st.integers(-1, 25), max_size=20))
def test_map_features_composes_like_matrix_products(i, j, ids):
    mats = bf.SIGNED_PERMUTATIONS
    ids = np.array(ids, dtype=np.int64)
    step = bf.map_features(i, bf.map_features(j, ids))
    assert np.array_equal(step, bf.map_features(mats[i] @ mats[j], ids))


# --- sign flips and relative poses ------------------------------------------------------------

def test_canonical_sign_flip_maps_into_the_non_negative_octant_with_ties_to_plus():
    rng = np.random.default_rng(1)
    v = rng.normal(size=(500, 3))
    v[:50, 0] = 0.0
    v[50:100, 1] = -0.0
    d = bf.canonical_sign_flip(v)
    assert d.shape == (500, 3) and set(np.unique(d)) == {-1, 1}
    assert np.all(d * v >= 0)
    assert np.all(d[:50, 0] == 1) and np.all(d[50:100, 1] == 1)
    k = bf.sign_flip_index(d)
    assert np.array_equal(bf.SIGNED_PERMUTATIONS[k], d[:, :, None] * np.eye(3))
    assert np.all(np.einsum("nij,nj->ni", bf.SIGNED_PERMUTATIONS[k], v) >= 0)


@pytest.mark.parametrize("size_a, size_b", [((1, 1, 1), (1, 1, 1)), ((1, 2, 3), (1, 1, 2)),
                                            ((2.438, 2.591, 12.192), (2.438, 2.591, 6.058))])
def test_proper_pairs_only_pair_equal_determinants(size_a, size_b):
    det_a = np.rint(np.linalg.det(bf.box_symmetries(size_a)))
    det_b = np.rint(np.linalg.det(bf.box_symmetries(size_b)))
    pairs = bf.proper_pairs(size_a, size_b)
    brute = [(i, j) for i in range(len(det_a)) for j in range(len(det_b)) if det_a[i] == det_b[j]]
    assert [tuple(p) for p in pairs] == brute
    assert len(pairs) == len(det_a) * len(det_b) // 2


def test_symmetry_pairs_keep_the_relative_pose_a_rotation_and_the_same_contact_geometry():
    size_a, size_b = (1.0, 2.0, 3.0), (1.0, 1.0, 2.0)
    rng = np.random.default_rng(2)
    syms_a, syms_b = bf.box_symmetries(size_a), bf.box_symmetries(size_b)
    ia, ib = bf.box_symmetry_indices(size_a), bf.box_symmetry_indices(size_b)
    verts_b = bf.vertex_positions(size_b)
    for R, t in zip(Rotation.random(20, random_state=3).as_matrix(), rng.normal(size=(20, 3))):
        world_b = verts_b @ R.T + t  # B's vertices in A's frame
        for i, j in bf.proper_pairs(size_a, size_b):
            S, T = syms_a[i], syms_b[j]
            R2, t2 = S @ R @ T.T, S @ t
            assert np.isclose(np.linalg.det(R2), 1.0)
            assert np.allclose(R2 @ R2.T, np.eye(3))
            # vertex v of B lands, in the new pose, where S puts its old position
            image = bf.map_features(ib[j], np.arange(18, 26)) - bf.VERTEX_BASE
            assert np.allclose(verts_b[image] @ R2.T + t2, world_b @ S.T)
            # a point on A's face f maps onto face perm_S(f) of A
            f_img = bf.map_features(ia[i], np.arange(6))
            assert np.allclose(bf.face_centers(size_a) @ S.T, bf.face_centers(size_a)[f_img])
    unequal = [(i, j) for i in range(len(syms_a)) for j in range(len(syms_b))
               if np.linalg.det(syms_a[i]) * np.linalg.det(syms_b[j]) < 0]
    i, j = unequal[0]  # the pairs left out would turn R into a reflection
    assert np.isclose(np.linalg.det(syms_a[i] @ R @ syms_b[j].T), -1.0)
