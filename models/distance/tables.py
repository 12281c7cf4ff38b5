"""Flat hull tables of the distance query: every hull's vertices in one array, from a list of
vertex arrays (each hulled by :func:`impactnet.models.compound.hull.convex_hull`, so interior
and edge points are dropped)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.hull import Hull, convex_hull


@dataclass(frozen=True)
class HullTables:
    """H convex hulls, body frames, metres, as the compiled row function reads them.

    Attributes
    ----------
    vertices : ndarray of float64, shape (V, 3)
        The corners of every hull, hull after hull.
    vertex_start : ndarray of int64, shape (H + 1,)
        Hull ``h``'s corners are ``vertices[vertex_start[h]:vertex_start[h + 1]]``.
    hull_size : ndarray of float64, shape (H, 2)
        Per hull: its largest half-extent (m, the scale of its tolerances) and its reach, the
        largest distance of a corner from the body's origin (m, the magnitude of its
        coordinates, for the rounding of GJK's direction).
    """

    vertices: np.ndarray
    vertex_start: np.ndarray
    hull_size: np.ndarray

    @property
    def n_hulls(self) -> int:
        return len(self.hull_size)

    @property
    def max_vertices(self) -> int:
        """The most corners of one hull."""
        return int(np.diff(self.vertex_start).max())


def tables_of_hulls(hulls: list[Hull] | tuple[Hull, ...]) -> HullTables:
    """The tables of already built hulls (:mod:`impactnet.models.compound.hull`)."""
    if not hulls:
        raise ValueError("hull tables need at least one hull")
    vertices = np.ascontiguousarray(np.concatenate([h.vertices for h in hulls]), np.float64)
    start = np.concatenate([[0], np.cumsum([len(h.vertices) for h in hulls])]).astype(np.int64)
    size = np.array([[h.half_extent, float(np.linalg.norm(h.vertices, axis=1).max())]
                     for h in hulls], np.float64)
    for array in (vertices, start, size):
        array.setflags(write=False)
    return HullTables(vertices, start, size)


def hull_tables(vertex_arrays) -> HullTables:
    """The tables of the hulls of ``vertex_arrays``: a list of (k_h, 3) arrays, metres, body frames
    (a box: its 8 corners). Raises :class:`~impactnet.models.compound.parts.PartError` for points
    that span no volume."""
    return tables_of_hulls([convex_hull(np.asarray(v, np.float64), f"polytope {k}")
                            for k, v in enumerate(vertex_arrays)])
