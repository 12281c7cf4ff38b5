"""The Python entry of the distance query: N poses of one pair of convex polytopes.

:func:`polytope_gaps` takes the two polytopes' vertices (body frames; a box is its 8 corners)
and N poses of each body, and returns :class:`Gaps` (world frame, metres). The pair's hull
tables are built once per pair of vertex arrays (cached, :data:`PAIR_CACHE_SIZE` pairs);
:class:`PolytopePair` keeps them explicitly. Batches of
:data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` rows or more run on the parallel kernel,
launched chunk by chunk (:func:`impactnet.models.compiled.launch`,
:func:`~impactnet.models.compiled.chunks`).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from impactnet.models import compiled
from impactnet.models.distance.kernels import gap_rows_parallel, gap_rows_serial
from impactnet.models.distance.tables import HullTables, hull_tables
from impactnet.models.geometry.rotations import quaternion_to_matrix

#: Pairs of vertex arrays whose hull tables :func:`polytope_gaps` keeps.
PAIR_CACHE_SIZE = 64


@dataclass
class Gaps:
    """The gaps of N poses of a pair of polytopes, world frame.

    Attributes
    ----------
    distance : ndarray of float64, shape (n,)
        The distance (m): > 0 when separated, 0 when touching or overlapping (no depth).
    point_a, point_b : ndarray of float64, shape (n, 3)
        The closest points on A and on B (m), ``point_b - point_a = distance * direction``;
        where they are not unique, those under and over the closest region's centroid.
        Touching or overlapping: a point of both bodies (touching along a face or an edge
        pair: the touching region's centroid).
    point : ndarray of float64, shape (n, 3)
        Their midpoint (m): the closest region's centroid on the mid-plane.
    direction : ndarray of float64, shape (n, 3)
        Unit direction from A towards B; 0 when touching or overlapping.
    colliding : ndarray of bool, shape (n,)
        Touching or overlapping (``distance == 0``).
    """

    distance: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    point: np.ndarray
    direction: np.ndarray
    colliding: np.ndarray


def _positions(value, n: int) -> np.ndarray:
    """(n, 3) contiguous float64 from a (3,) or (n, 3) position."""
    value = np.asarray(value, np.float64)
    if value.shape == (n, 3) or (n == 1 and value.shape == (3,)):
        return np.ascontiguousarray(value).reshape(n, 3)
    if value.shape not in ((3,), (1, 3)):
        raise ValueError(f"positions must be (3,) or ({n}, 3), got {value.shape}")
    return np.ascontiguousarray(np.broadcast_to(value, (n, 3)))


def _rotations(value, n: int) -> np.ndarray:
    """(n, 3, 3) contiguous float64 from matrices (3, 3) / (n, 3, 3) or unit quaternions
    [w, x, y, z] (4,) / (n, 4)."""
    value = np.asarray(value, np.float64)
    if value.shape[-1:] == (4,) and value.ndim <= 2:
        value = quaternion_to_matrix(value)
    if value.shape == (n, 3, 3) or (n == 1 and value.shape == (3, 3)):
        return np.ascontiguousarray(value).reshape(n, 3, 3)
    if value.shape not in ((3, 3), (1, 3, 3)):
        raise ValueError(f"rotations must be (3, 3), ({n}, 3, 3), (4,) or ({n}, 4), got "
                         f"{value.shape}")
    return np.ascontiguousarray(np.broadcast_to(value, (n, 3, 3)))


class PolytopePair:
    """Two convex polytopes' hull tables (hull 0 is A, hull 1 is B), for many batches."""

    def __init__(self, vertices_a, vertices_b):
        self.tables: HullTables = hull_tables([vertices_a, vertices_b])

    def gaps(self, position_a, rotation_a, position_b, rotation_b) -> Gaps:
        """The gaps at N poses (:func:`polytope_gaps`)."""
        n = _batch_rows(position_a, rotation_a, position_b, rotation_b)
        poses = (_positions(position_a, n), _rotations(rotation_a, n),
                 _positions(position_b, n), _rotations(rotation_b, n))
        outs = (np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
                np.empty((n, 3)), np.empty(n, np.bool_))
        t = self.tables
        tables = (t.vertices, t.vertex_start, t.hull_size)
        for start, stop in compiled.chunks(n):
            if stop - start >= compiled.PARALLEL_MIN_ROWS:
                compiled.launch(gap_rows_parallel, tables, (0, 1), poses, start, stop, outs)
            else:
                gap_rows_serial(tables, (0, 1), poses, start, stop, outs)
        return Gaps(*outs)


def _batch_rows(position_a, rotation_a, position_b, rotation_b) -> int:
    """N: the leading length of the batched pose inputs (positions (n, 3), matrices
    (n, 3, 3), quaternions (n, 4)); 1 if none is batched."""
    n = 1
    for value, single in ((position_a, 1), (rotation_a, 2), (position_b, 1), (rotation_b, 2)):
        shape = np.shape(value)
        if len(shape) > single or (single == 2 and len(shape) == 2 and shape[1] == 4):
            if n not in (1, shape[0]):
                raise ValueError(f"pose inputs of {n} and {shape[0]} rows")
            n = shape[0]
    return n


@lru_cache(maxsize=PAIR_CACHE_SIZE)
def _pair(key_a: bytes, shape_a: tuple, key_b: bytes, shape_b: tuple) -> PolytopePair:
    return PolytopePair(np.frombuffer(key_a).reshape(shape_a),
                        np.frombuffer(key_b).reshape(shape_b))


def polytope_gaps(vertices_a, vertices_b, position_a, rotation_a, position_b,
                  rotation_b) -> Gaps:
    """The signed gap, closest points and direction between two convex polytopes at N poses.

    Parameters
    ----------
    vertices_a, vertices_b : array_like, shape (k_a, 3) and (k_b, 3)
        The polytopes' points (m, body frames; their hulls are taken, a box is its corners).
    position_a, position_b : array_like, shape (3,) or (n, 3)
        The bodies' positions (m, world frame).
    rotation_a, rotation_b : array_like, shape (3, 3), (n, 3, 3), (4,) or (n, 4)
        The bodies' rotations (``x_world = R x_body + p``), or unit quaternions [w, x, y, z].

    Returns
    -------
    Gaps
        N rows, world frame (:class:`Gaps`).
    """
    a = np.ascontiguousarray(vertices_a, np.float64)
    b = np.ascontiguousarray(vertices_b, np.float64)
    pair = _pair(a.tobytes(), a.shape, b.tobytes(), b.shape)
    return pair.gaps(position_a, rotation_a, position_b, rotation_b)


@compiled.on_warm_up(serving=False)  # a library entry: no request calls it
def warm_up() -> None:
    """Compile (or load) the kernels on a box over a box, serial and parallel."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    for rows in (1, compiled.PARALLEL_MIN_ROWS):
        polytope_gaps(corners, corners, np.zeros((rows, 3)), np.eye(3),
                      np.array([0.0, 0.0, 3.0]), np.eye(3))
