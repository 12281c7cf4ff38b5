"""Box features with stable, unified ids, in one import: the ids and their tables
(:mod:`~impactnet.models.geometry.box_feature_ids`: faces 0-5, edges 6-17, vertices 18-25, -1
none, and their sign vectors), the geometry of a box of a given size
(:mod:`~impactnet.models.geometry.box_feature_geometry`) and the 48 signed permutations that map
a box onto itself with their action on ids and on a relative pose
(:mod:`~impactnet.models.geometry.box_symmetries`). Each module's docstring states its rules.
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
