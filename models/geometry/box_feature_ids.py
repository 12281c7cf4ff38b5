"""Box features with stable, unified ids: the id functions, the read-only tables built from them
(sign vectors, adjacency, the 48 signed permutations and their action on ids) and the kind and
name of an id.

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
"""
from __future__ import annotations

import itertools

import numpy as np

FACE_BASE, EDGE_BASE, VERTEX_BASE = 0, 6, 18
NO_FEATURE = -1
N_FACES, N_EDGES, N_VERTICES = 6, 12, 8
N_FEATURES = N_FACES + N_EDGES + N_VERTICES


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


def id_of_signs(signs):
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
        face_vertices[f] = id_of_signs(corners)
    ring = FEATURE_SIGNS[face_vertices]                       # edge k: vertices k, k + 1
    face_edges = id_of_signs((ring + np.roll(ring, -1, axis=1)) // 2)
    ends = edge_sig[:, None] + np.array([-1, 1])[:, None] * eye[EDGE_AXIS][:, None]
    other_axes = np.array([[1, 2], [0, 2], [0, 1]])[EDGE_AXIS]  # (12, 2): j < l
    edge_faces = id_of_signs(eye[other_axes] * edge_sig[:, None])
    vertex_faces = id_of_signs(eye[None] * vert_sig[:, None])
    vertex_edges = id_of_signs((1 - eye)[None] * vert_sig[:, None])
    return (face_vertices, face_edges, id_of_signs(ends), edge_faces, vertex_faces,
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
    id_of_signs(FEATURE_SIGNS @ np.swapaxes(SIGNED_PERMUTATIONS, -1, -2)))
#: Readable name of every feature id (26,), e.g. "face +x", "edge x(+y,-z)", "vertex (+,-,+)".
FEATURE_NAMES = tuple(_name_of_signs(sigma) for sigma in FEATURE_SIGNS)
_KIND_NAMES = np.array(["face", "edge", "vertex", "none"])
_ALL_NAMES = np.array(FEATURE_NAMES + ("none",))  # index -1 -> "none"



def check_ids(ids):
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
    ids = check_ids(ids)
    kind = (ids >= EDGE_BASE).astype(np.int64) + (ids >= VERTEX_BASE)
    return _KIND_NAMES[np.where(ids == NO_FEATURE, 3, kind)]


def feature_name(ids):
    """Readable name(s), e.g. ``"face +x"``, ``"edge x(+y,-z)"``, ``"vertex (+,-,+)"``.

    A scalar id gives a ``str``, an array of ids an ndarray of str of the same shape; -1 gives
    ``"none"``.
    """
    ids = check_ids(ids)
    names = _ALL_NAMES[ids]
    return str(names) if ids.ndim == 0 else names
