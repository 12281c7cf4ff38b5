"""Box features with stable, unified ids.

A box has half-extents ``h = size / 2`` in its own frame, centred at the origin.

Ids (one integer space, so an id alone says what kind of feature it is):

* faces 0-5: ``2 * axis + negative`` -> 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z;
* edges 6-17: the edge parallel to ``axis`` i, at the signs of the two other axes j < l
  (ascending order): ``6 + 4 * i + 2 * (s_j < 0) + (s_l < 0)``;
* vertices 18-25: ``18 + 4 * (s_x < 0) + 2 * (s_y < 0) + (s_z < 0)``;
* -1: no feature (separated pair).

Every feature has a *sign vector* sigma in {-1, 0, +1}^3 (:data:`FEATURE_SIGNS`): its centre
is ``sigma * h``; a face has one non-zero entry, an edge two (0 along its axis), a vertex three.
The 26 non-zero sign vectors and the 26 features are in bijection.

Symmetries. :data:`SIGNED_PERMUTATIONS` holds the 48 signed permutation matrices S (rotations,
det +1, and reflections, det -1), ``(S x)_r = s_r * x[p[r]]``, at index ``8 * k + 4 * (s_0 < 0)
+ 2 * (s_1 < 0) + (s_2 < 0)`` with k the rank of p in ``itertools.permutations(range(3))``:
index 0 is the identity, 0-7 the pure sign flips. S maps the box onto itself when it permutes
only axes of equal size (:func:`box_symmetries`); then the feature with sign vector sigma goes
to the one with sign vector ``S sigma`` (:func:`feature_permutation`).

Acting on a relative pose. Let B sit in A's frame at position t with rotation R (a point
``x_B`` of B is at ``R x_B + t`` in A's frame). Relabel A's frame by a symmetry S of A and
B's frame by a symmetry T of B (``x_A' = S x_A``, ``x_B' = T x_B``); both boxes are unchanged
as sets, so the same physical contact is described by the pose::

    t -> S t,    R -> S R T^T,

with A's features mapped by ``feature_permutation(S)``, B's by ``feature_permutation(T)``,
and the contact normal and point, both in A's frame, by ``n -> S n``, ``p -> S p``; depth and
contact type are unchanged (world-frame results are first brought into A's frame). Since
``det(S R T^T) = det(S) det(T)``, a reflection S keeps R a proper rotation only when paired
with a reflection T: the pair must have ``det(S) == det(T)`` (:func:`proper_pairs`).
"""
from __future__ import annotations

import itertools

import numpy as np

FACE_BASE, EDGE_BASE, VERTEX_BASE = 0, 6, 18
NO_FEATURE = -1
N_FACES, N_EDGES, N_VERTICES = 6, 12, 8
N_FEATURES = N_FACES + N_EDGES + N_VERTICES

#: Relative tolerance (dimensionless) under which two box sizes count as equal, so that the
#: axis permutation swapping them is a symmetry. 1e-6 absorbs round-off of sizes that went
#: through float32 (2**-24 ~ 6e-8) or a text round-trip, yet on a 12 m container it is 12 um,
#: far below manufacturing tolerances and the penetration depths that matter, so treating such
#: boxes as equal moves no contact measurably.
SIZE_REL_TOL = 1e-6


def face_id(axis, negative):
    """Face id from its normal axis (0-2) and side; arrays broadcast, int result."""
    return FACE_BASE + 2 * np.asarray(axis) + np.asarray(negative, dtype=int)


def edge_id(axis, negative_j, negative_l):
    """Edge id from its direction axis i and the signs of the other two axes j < l."""
    return (
        EDGE_BASE
        + 4 * np.asarray(axis)
        + 2 * np.asarray(negative_j, dtype=int)
        + np.asarray(negative_l, dtype=int)
    )


def vertex_id(negative_x, negative_y, negative_z):
    """Vertex id from the signs of its three coordinates (True = negative)."""
    return (
        VERTEX_BASE
        + 4 * np.asarray(negative_x, dtype=int)
        + 2 * np.asarray(negative_y, dtype=int)
        + np.asarray(negative_z, dtype=int)
    )


# ---------------------------------------------------------------------------------------------
# Tables, built once at import from the id functions above (read-only int arrays).

def _build_signs():
    """Sign vectors (26, 3) of all features, indexed by id."""
    signs = np.zeros((N_FEATURES, 3), dtype=np.int64)
    for axis, neg in itertools.product(range(3), (0, 1)):
        signs[face_id(axis, neg), axis] = 1 - 2 * neg
    for axis, nj, nl in itertools.product(range(3), (0, 1), (0, 1)):
        j, l = [a for a in range(3) if a != axis]
        signs[edge_id(axis, nj, nl), [j, l]] = (1 - 2 * nj, 1 - 2 * nl)
    for nx, ny, nz in itertools.product((0, 1), repeat=3):
        signs[vertex_id(nx, ny, nz)] = (1 - 2 * nx, 1 - 2 * ny, 1 - 2 * nz)
    return signs


def _id_of_signs(signs):
    """Feature ids of sign vectors (..., 3) in {-1, 0, 1}; -1 for the zero vector."""
    signs = np.asarray(signs)
    codes = ((signs + 1) * np.array([9, 3, 1])).sum(-1)
    return _CODE_TO_ID[codes]


def _build_adjacency():
    """The adjacency tables, in the order of their assignment below."""
    eye = np.eye(3, dtype=np.int64)
    edge_sig, vert_sig = FEATURE_SIGNS[EDGE_BASE:VERTEX_BASE], FEATURE_SIGNS[VERTEX_BASE:]
    square = np.array([(1, 1), (-1, 1), (-1, -1), (1, -1)])  # CCW about e_b x e_c = e_axis
    face_vertices = np.zeros((N_FACES, 4), dtype=np.int64)
    for f in range(N_FACES):
        axis, s = f // 2, FEATURE_SIGNS[f].sum()
        corners = np.full((4, 3), s)
        corners[:, [(axis + 1) % 3, (axis + 2) % 3]] = square if s > 0 else square[::-1]
        face_vertices[f] = _id_of_signs(corners)
    ring = FEATURE_SIGNS[face_vertices]                       # edge k: vertices k, k + 1
    face_edges = _id_of_signs((ring + np.roll(ring, -1, axis=1)) // 2)
    ends = edge_sig[:, None] + np.array([-1, 1])[:, None] * eye[EDGE_AXIS][:, None]
    other_axes = np.array([[1, 2], [0, 2], [0, 1]])[EDGE_AXIS]  # (12, 2): j < l
    edge_faces = _id_of_signs(eye[other_axes] * edge_sig[:, None])
    vertex_faces = _id_of_signs(eye[None] * vert_sig[:, None])
    vertex_edges = _id_of_signs((1 - eye)[None] * vert_sig[:, None])
    return (face_vertices, face_edges, _id_of_signs(ends), edge_faces, vertex_faces,
            vertex_edges)


def _build_signed_permutations():
    """The 48 signed permutation matrices (48, 3, 3), ordered as in the module docstring."""
    perms = np.eye(3, dtype=np.int64)[list(itertools.permutations(range(3)))]  # row r: e_p[r]
    signs = np.array(list(itertools.product((1, -1), repeat=3)))
    return (signs[None, :, :, None] * perms[:, None]).reshape(48, 3, 3)


def _name_of_signs(sigma):
    """Readable name of the feature with sign vector ``sigma``."""
    sign = {1: "+", -1: "-"}
    axes = np.flatnonzero(sigma)
    if len(axes) == 1:
        return f"face {sign[sigma[axes[0]]]}{'xyz'[axes[0]]}"
    if len(axes) == 2:
        along = "xyz"[int(np.flatnonzero(sigma == 0)[0])]
        return f"edge {along}(" + ",".join(sign[sigma[a]] + "xyz"[a] for a in axes) + ")"
    return "vertex (" + ",".join(sign[c] for c in sigma) + ")"


def _frozen(a):
    a.setflags(write=False)
    return a


#: Sign vector of every feature id (26, 3), entries in {-1, 0, 1}; centre = sign * size / 2.
FEATURE_SIGNS = _frozen(_build_signs())
_CODE_TO_ID = np.full(27, NO_FEATURE, dtype=np.int64)
_CODE_TO_ID[((FEATURE_SIGNS + 1) * np.array([9, 3, 1])).sum(-1)] = np.arange(N_FEATURES)
_frozen(_CODE_TO_ID)
#: Normal axis of each face (6,) and direction axis of each edge (12,).
FACE_AXIS = _frozen(np.arange(N_FACES) // 2)
EDGE_AXIS = _frozen(np.arange(N_EDGES) // 4)
#: FACE_VERTICES (6, 4): vertex ids, counter-clockwise seen from outside the face.
#: FACE_EDGES (6, 4): edge k joins FACE_VERTICES[f, k] and FACE_VERTICES[f, (k + 1) % 4].
#: EDGE_VERTICES (12, 2): vertex ids at the minus end, then the plus end, along the edge axis.
#: EDGE_FACES (12, 2): the two faces containing the edge (normal axis j, then l; j < l).
#: VERTEX_FACES, VERTEX_EDGES (8, 3): the faces normal to / edges along x, y, z at the vertex;
#: all rows indexed by ``id - base`` of the first feature, entries are full ids.
(FACE_VERTICES, FACE_EDGES, EDGE_VERTICES, EDGE_FACES, VERTEX_FACES,
 VERTEX_EDGES) = (_frozen(t) for t in _build_adjacency())
#: The 48 signed permutation matrices (48, 3, 3), int; index 0 is the identity.
SIGNED_PERMUTATIONS = _frozen(_build_signed_permutations())
#: Determinant (+1 rotation, -1 reflection) of each signed permutation (48,).
SIGNED_PERMUTATION_DETS = _frozen(np.rint(np.linalg.det(SIGNED_PERMUTATIONS)).astype(np.int64))
#: Image of every feature id under every signed permutation (48, 26), by index.
FEATURE_PERMUTATIONS = _frozen(
    _id_of_signs(FEATURE_SIGNS @ np.swapaxes(SIGNED_PERMUTATIONS, -1, -2)))
#: Readable name of every feature id (26,), e.g. "face +x", "edge x(+y,-z)", "vertex (+,-,+)".
FEATURE_NAMES = tuple(_name_of_signs(sigma) for sigma in FEATURE_SIGNS)
_KIND_NAMES = np.array(["face", "edge", "vertex", "none"])
_ALL_NAMES = np.array(FEATURE_NAMES + ("none",))  # index -1 -> "none"


# ---------------------------------------------------------------------------------------------
# Geometry tables as functions of the full size (lx, ly, lz), metres.

def _half(size):
    """Half-extents (..., 1, 3) of full sizes (..., 3)."""
    return 0.5 * np.asarray(size, dtype=np.float64)[..., None, :]


def face_normals():
    """Outward unit normals of the faces in the box frame, float64, shape (6, 3), by face id."""
    return FEATURE_SIGNS[FACE_BASE:EDGE_BASE].astype(np.float64)


def face_centers(size):
    """Face centres (..., 6, 3), float64, metres, box frame; row ``f`` is face id ``f``.

    ``size`` (..., 3): full edge lengths in metres.
    """
    return FEATURE_SIGNS[FACE_BASE:EDGE_BASE] * _half(size)


def edge_directions():
    """Unit direction (the +axis) of each edge, float64, shape (12, 3), row ``id - 6``."""
    return np.eye(3)[EDGE_AXIS]


def edge_centers(size):
    """Edge midpoints (..., 12, 3), float64, metres, box frame; row ``e`` is edge id ``6 + e``.

    ``size`` (..., 3): full edge lengths in metres.
    """
    return FEATURE_SIGNS[EDGE_BASE:VERTEX_BASE] * _half(size)


def edge_lengths(size):
    """Edge lengths in metres, shape (..., 12), row ``e`` for edge id ``6 + e``."""
    return np.asarray(size, dtype=np.float64)[..., EDGE_AXIS]


def vertex_positions(size):
    """Vertex positions (..., 8, 3), float64, metres, box frame; row ``v`` is id ``18 + v``.

    ``size`` (..., 3): full edge lengths in metres. Coordinate signs are those of the id.
    """
    return FEATURE_SIGNS[VERTEX_BASE:] * _half(size)


def _check_ids(ids):
    """Integer array of ids; raises ValueError outside -1..25."""
    ids = np.asarray(ids)
    if ids.size and (not np.issubdtype(ids.dtype, np.integer)
                     or ids.min() < NO_FEATURE or ids.max() >= N_FEATURES):
        raise ValueError(f"feature ids must be integers in [-1, {N_FEATURES - 1}]")
    return ids.astype(np.int64)


def feature_kind(ids):
    """Kind of each feature id (any shape, -1..25): ndarray of str, same shape.

    Entries are ``"face"``, ``"edge"``, ``"vertex"`` or ``"none"`` (for -1).
    """
    ids = _check_ids(ids)
    kind = (ids >= EDGE_BASE).astype(np.int64) + (ids >= VERTEX_BASE)
    return _KIND_NAMES[np.where(ids == NO_FEATURE, 3, kind)]


def feature_name(ids):
    """Readable name(s), e.g. ``"face +x"``, ``"edge x(+y,-z)"``, ``"vertex (+,-,+)"``.

    A scalar id gives a ``str``, an array of ids an ndarray of str of the same shape; -1 gives
    ``"none"``.
    """
    ids = _check_ids(ids)
    names = _ALL_NAMES[ids]
    return str(names) if ids.ndim == 0 else names


# ---------------------------------------------------------------------------------------------
# Symmetries.

def box_symmetry_indices(size, rel_tol=SIZE_REL_TOL):
    """Indices into :data:`SIGNED_PERMUTATIONS` of the symmetries of one box.

    Sizes are grouped by chaining: after sorting, neighbours within ``rel_tol`` (relative to
    the larger) are equal, so the result is always a group even when ``a ~ b ~ c`` but not
    ``a ~ c``. All 8 sign flips always qualify.

    Parameters
    ----------
    size : array_like, shape (3,)
        Full edge lengths in metres.
    rel_tol : float
        Relative size tolerance (dimensionless), default :data:`SIZE_REL_TOL`.

    Returns
    -------
    ndarray of int64, shape (m,)
        Ascending; m is 8, 16 or 48.
    """
    size = np.asarray(size, dtype=np.float64)
    if size.shape != (3,) or not np.all(np.isfinite(size) & (size > 0)):
        raise ValueError("size must be 3 finite positive lengths")
    order = np.argsort(size)
    s = size[order]
    new_group = np.diff(s) > rel_tol * s[1:]  # sorted, positive: s[1:] is the larger
    label = np.empty(3, dtype=np.int64)
    label[order] = np.concatenate([[0], np.cumsum(new_group)])
    perm_label = np.abs(SIGNED_PERMUTATIONS) @ label  # label[p[r]] for row r
    return np.flatnonzero(np.all(perm_label == label, axis=-1))


def box_symmetries(size, rel_tol=SIZE_REL_TOL):
    """Signed permutations that map the box of ``size`` onto itself, int, shape (m, 3, 3).

    See :func:`box_symmetry_indices`: 48 for a cube, 16 with two equal sizes, else 8.
    """
    return SIGNED_PERMUTATIONS[box_symmetry_indices(size, rel_tol)]


def feature_permutation(S):
    """Where each feature goes under ``x -> S x``.

    Parameters
    ----------
    S : array_like, matrices (..., 3, 3) or int indices (...) into SIGNED_PERMUTATIONS
        Signed permutations; meaningful for a box whose sizes S preserves.

    Returns
    -------
    ndarray of int64, shape (..., 26)
        ``perm[f]`` is the id of the image of feature ``f`` (kind preserved). Composition:
        ``feature_permutation(S1 @ S2) == feature_permutation(S1)[feature_permutation(S2)]``.
    """
    s = np.asarray(S)
    if s.shape[-2:] != (3, 3):
        if not np.issubdtype(s.dtype, np.integer) or np.any((s < 0) | (s >= 48)):
            raise ValueError("S must be matrices (..., 3, 3) or integer indices in 0..47")
        return FEATURE_PERMUTATIONS[s]
    m = np.rint(s).astype(np.int64)
    if (not np.allclose(s, m) or np.any(np.abs(m) > 1)
            or np.any(np.abs(m).sum(-1) != 1) or np.any(np.abs(m).sum(-2) != 1)):
        raise ValueError("S must be signed permutation matrices")
    return _id_of_signs(FEATURE_SIGNS @ np.swapaxes(m, -1, -2))  # row f: id of S sigma_f


def map_features(S, ids):
    """Apply symmetries to feature ids, keeping -1 as -1.

    Parameters
    ----------
    S : array_like, int indices (b...) into SIGNED_PERMUTATIONS or matrices (b..., 3, 3)
        The symmetries.
    ids : array_like of int, shape broadcastable with (b...)
        Feature ids in -1..25.

    Returns
    -------
    ndarray of int64, broadcast shape of (b...) and ``ids.shape``
    """
    ids = _check_ids(ids)
    table = feature_permutation(S)
    table = np.concatenate([table, np.full(table.shape[:-1] + (1,), NO_FEATURE)], axis=-1)
    shape = np.broadcast_shapes(table.shape[:-1], ids.shape)
    table = np.broadcast_to(table, shape + (N_FEATURES + 1,))
    return np.take_along_axis(table, np.broadcast_to(ids, shape)[..., None], axis=-1)[..., 0]


def canonical_sign_flip(v):
    """Diagonal ``d`` (..., 3), int +-1, of the sign matrix that maps ``v`` into ``d * v >= 0``.

    ``v`` (..., 3): vectors in any unit (e.g. metres). Ties (0 and -0.0) give +1;
    ``sign_flip_index(d)`` is the index of ``diag(d)`` in :data:`SIGNED_PERMUTATIONS`.
    """
    return np.where(np.asarray(v) < 0, -1, 1).astype(np.int64)


def sign_flip_index(d):
    """Index (...,) into :data:`SIGNED_PERMUTATIONS` of the sign flips ``diag(d)``, d (..., 3)."""
    neg = (np.asarray(d) < 0).astype(np.int64)
    return 4 * neg[..., 0] + 2 * neg[..., 1] + neg[..., 2]


def proper_pairs(size_a, size_b, rel_tol=SIZE_REL_TOL):
    """Pairs of symmetries (S of A, T of B) with ``det(S) == det(T)``, keeping R proper.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,)
        Full sizes of boxes A and B in metres.
    rel_tol : float
        Relative size tolerance, see :func:`box_symmetry_indices`.

    Returns
    -------
    ndarray of int64, shape (k, 2)
        Rows ``(i, j)``: ``box_symmetries(size_a)[i]`` with ``box_symmetries(size_b)[j]``,
        ordered by i then j.
    """
    det_a = SIGNED_PERMUTATION_DETS[box_symmetry_indices(size_a, rel_tol)]
    det_b = SIGNED_PERMUTATION_DETS[box_symmetry_indices(size_b, rel_tol)]
    return np.argwhere(det_a[:, None] == det_b[None, :]).astype(np.int64)
