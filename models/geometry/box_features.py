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

The ids and their tables live in :mod:`~impactnet.models.geometry.box_feature_ids`, the
geometry of a box of a given size in :mod:`~impactnet.models.geometry.box_feature_geometry` and
the symmetries in :mod:`~impactnet.models.geometry.box_symmetries`; every name is importable
from here.
"""
from __future__ import annotations

from impactnet.models.geometry.box_feature_geometry import (
    edge_centers,
    edge_directions,
    edge_lengths,
    face_centers,
    face_normals,
    vertex_positions,
)
from impactnet.models.geometry.box_feature_ids import (
    EDGE_AXIS,
    EDGE_BASE,
    EDGE_FACES,
    EDGE_VERTICES,
    FACE_AXIS,
    FACE_BASE,
    FACE_EDGES,
    FACE_VERTICES,
    FEATURE_NAMES,
    FEATURE_PERMUTATIONS,
    FEATURE_SIGNS,
    N_EDGES,
    N_FACES,
    N_FEATURES,
    N_VERTICES,
    NO_FEATURE,
    SIGNED_PERMUTATION_DETS,
    SIGNED_PERMUTATIONS,
    VERTEX_BASE,
    VERTEX_EDGES,
    VERTEX_FACES,
    edge_id,
    face_id,
    feature_kind,
    feature_name,
    vertex_id,
)
from impactnet.models.geometry.box_symmetries import (
    SIZE_REL_TOL,
    box_symmetries,
    box_symmetry_indices,
    canonical_sign_flip,
    feature_permutation,
    map_features,
    proper_pairs,
    sign_flip_index,
)

__all__ = ["EDGE_AXIS", "EDGE_BASE", "EDGE_FACES", "EDGE_VERTICES", "FACE_AXIS", "FACE_BASE",
           "FACE_EDGES", "FACE_VERTICES", "FEATURE_NAMES", "FEATURE_PERMUTATIONS", "FEATURE_SIGNS",
           "NO_FEATURE", "N_EDGES", "N_FACES", "N_FEATURES", "N_VERTICES", "SIGNED_PERMUTATIONS",
           "SIGNED_PERMUTATION_DETS", "SIZE_REL_TOL", "VERTEX_BASE", "VERTEX_EDGES",
           "VERTEX_FACES", "box_symmetries", "box_symmetry_indices", "canonical_sign_flip",
           "edge_centers", "edge_directions", "edge_id", "edge_lengths", "face_centers", "face_id",
           "face_normals", "feature_kind", "feature_name", "feature_permutation", "map_features",
           "proper_pairs", "sign_flip_index", "vertex_id", "vertex_positions"]
