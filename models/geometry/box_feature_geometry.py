"""Box feature geometry as functions of the full size ``(lx, ly, lz)`` in metres, box frame:
face normals and centres, edge directions, centres and lengths, vertex positions (rows by
feature id, :mod:`impactnet.models.geometry.box_feature_ids`)."""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.box_feature_ids import (
    EDGE_AXIS,
    EDGE_BASE,
    FACE_BASE,
    FEATURE_SIGNS,
    VERTEX_BASE,
)


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
