"""The gap between two bodies made of parts: the smallest gap over their part pairs, with the
closest part pair, compiled (issue #34; a separated pair's normal, issue #33).

Per row (one pose of two bodies), by branch and bound: every part pair's lower bound is the distance
between A's part's bounds and B's part's bounds as seen in A's frame (B's box of bounds turned into
A's frame and bounded again: a box that holds the part); the pairs are visited in increasing bound,
each solved exactly (:func:`~impactnet.models.distance.kernels.gap_row`), until the next bound is no
smaller than the best gap found, or than the ``limit`` the caller cares about (a frame's margin:
pairs farther apart need no answer). A box is a body of one part.

Answers in the world frame: the gap (m; 0 touching or overlapping), the closest points on A
and B and their midpoint (the closest region's centroid where it is not unique), the unit
direction from A towards B, and the closest part pair (-1, -1 beyond the limit). Where other
part pairs are as close as the closest one (within the support slack of the distance query,
:data:`~impactnet.models.distance.tolerances.SUPPORT_REL` x the largest part's half extent:
ties of rounding, such as the four twistlocks of a level spreader over a container), the
closest points are the mean of every tied pair's, so that the point is the closest region's
centroid at the body level too and meets the centre of pressure as the gap closes.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from impactnet.models import compiled
from impactnet.models.distance.kernels import gap_row, scratch_slots
from impactnet.models.distance.tables import HullTables, tables_of_hulls
from impactnet.models.distance.tolerances import SUPPORT_REL
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import quaternion_to_matrix

#: Part pairs a row may hold in its bounds buffer (bodies of more parts are refused earlier:
#: 128 parts a body, inline).
MAX_PART_PAIRS = 1 << 16


@dataclass(frozen=True)
class BodyGaps:
    """The gaps of N poses of two bodies (module docstring), world frame."""

    distance: np.ndarray  # (n,) m; inf beyond the limit
    point_a: np.ndarray  # (n, 3)
    point_b: np.ndarray  # (n, 3)
    point: np.ndarray  # (n, 3)
    direction: np.ndarray  # (n, 3) unit, A towards B; 0 touching
    part_a: np.ndarray  # (n,) int64 closest parts; -1 beyond the limit
    part_b: np.ndarray


def _boxes(hulls) -> tuple[np.ndarray, np.ndarray]:
    """(centres (H, 3), half extents (H, 3)) of the hulls' bounds, body frames, metres."""
    centre = np.empty((len(hulls), 3))
    half = np.empty((len(hulls), 3))
    for h, hull in enumerate(hulls):
        lo, hi = hull.vertices.min(axis=0), hull.vertices.max(axis=0)
        centre[h], half[h] = 0.5 * (lo + hi), 0.5 * (hi - lo)
    return centre, half


@dataclass(frozen=True)
class PartTables:
    """The parts of one or more bodies as the gap kernel reads them (H hulls of B bodies, the
    bodies' hulls one after the other)."""

    tables: HullTables  # the H hulls, body frames, m
    centre: np.ndarray  # (H, 3) the centres of the hulls' bounds, m
    half: np.ndarray  # (H, 3) their half extents, m
    hulls: np.ndarray  # (B,) int64 the hulls of each body


#: A body table's part tables, built once per table (a scene body's table lives as long as
#: the scene: a batch of many small bodies against one container must not rebuild the
#: container's tables pair by pair).
_BODY_PARTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def box_bodies(sizes) -> PartTables:
    """The part tables of k box bodies of full edge lengths ``sizes`` (k, 3), metres, with no
    hull built: their corners (in the box hull's order), each one's largest half extent and its
    corners' reach, its bounds (the same arithmetic as a built hull's, so the same answers bit
    for bit; a batch of many distinct box sizes is one array operation, not a hull a size)."""
    sizes = np.asarray(sizes, np.float64).reshape(-1, 3)
    corners = bf.vertex_positions(sizes)  # (k, 8, 3)
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    extent = 0.5 * (hi - lo).max(axis=1)
    reach = np.linalg.norm(corners, axis=2).max(axis=1)
    k, per = corners.shape[:2]
    tables = HullTables(np.ascontiguousarray(corners.reshape(-1, 3)),
                        np.arange(0, k * per + 1, per, dtype=np.int64),
                        np.ascontiguousarray(np.stack([extent, reach], axis=1)))
    return PartTables(tables, 0.5 * (lo + hi), 0.5 * (hi - lo), np.ones(k, np.int64))


def _body_parts(table) -> PartTables:
    """The part tables of one body's table (:mod:`impactnet.models.compound.body_table`);
    :class:`PartTables` are taken as they are."""
    if isinstance(table, PartTables):
        return table
    found = _BODY_PARTS.get(table)
    if found is None:
        found = PartTables(tables_of_hulls(tuple(table.hulls)), *_boxes(table.hulls),
                           np.array([len(table.hulls)], np.int64))
        if not table.transient:
            _BODY_PARTS[table] = found
    return found


@compiled.jit
def _lower_bound(centre, half, i, j, t, r):
    """A lower bound of the gap between A's part i and B's part j: the distance between A's
    bounds and B's bounds turned into A's frame and bounded again."""
    total = 0.0
    for c in range(3):
        mid, reach = t[c], 0.0
        for m in range(3):
            mid += r[c, m] * centre[j, m]
            reach += abs(r[c, m]) * half[j, m]
        gap = abs(mid - centre[i, c]) - half[i, c] - reach
        if gap > 0.0:
            total += gap * gap
    return math.sqrt(total)


@compiled.jit
def _row(tables, centre, half, span, t, r, limit, tie, work, bounds, order_buf, one, out, row):
    """One pose (module docstring): the gap written at ``row`` of ``out`` (A's frame); A's
    parts are hulls ``span[0]:span[1]`` of ``tables``, B's ``span[2]:span[3]``."""
    vertices, start, size = tables
    n_hulls = size.shape[0]
    k = 0
    for i in range(span[0], span[1]):
        for j in range(span[2], span[3]):
            bounds[k] = _lower_bound(centre, half, i, j, t, r)
            order_buf[k] = i * n_hulls + j
            k += 1
    order = np.argsort(bounds[:k])
    distance, point_a, point_b, point, direction, part_a, part_b = out
    best = limit
    distance[row], part_a[row], part_b[row] = np.inf, -1, -1
    for m in range(k):
        pair = order_buf[order[m]]
        if bounds[order[m]] >= best:
            break
        i, j = pair // n_hulls, pair % n_hulls
        gap_row(vertices, start, size, i, j, t, r, work, 0, *one)
        if one[0][0] < best:
            best = one[0][0]
            distance[row], part_a[row], part_b[row] = best, i - span[0], j - span[2]
            for c in range(3):
                point_a[row, c], point_b[row, c] = one[1][0, c], one[2][0, c]
                point[row, c], direction[row, c] = one[3][0, c], one[4][0, c]
            if best <= 0.0:
                break
    if 0.0 < best < limit:
        _ties(tables, span, t, r, tie, work, bounds, order_buf, order, k, one, out, row)


@compiled.jit
def _ties(tables, span, t, r, tie, work, bounds, order_buf, order, k, one, out, row):
    """The closest region of a row whose closest part pair is not alone: every other part
    pair within ``tie`` (m) of the smallest gap adds its closest regions' centroids, and the
    row's closest points are their mean (a level spreader over a container: its four heads)."""
    vertices, start, size = tables
    n_hulls = size.shape[0]
    distance, point_a, point_b, point, direction, part_a, part_b = out
    best, count = distance[row], 1
    sums = np.empty((3, 3))
    for c in range(3):
        sums[0, c], sums[1, c], sums[2, c] = point_a[row, c], point_b[row, c], point[row, c]
    for m in range(k):
        pair = order_buf[order[m]]
        if bounds[order[m]] > best + tie:
            break
        i, j = pair // n_hulls, pair % n_hulls
        if i - span[0] == part_a[row] and j - span[2] == part_b[row]:
            continue
        gap_row(vertices, start, size, i, j, t, r, work, 0, *one)
        if one[0][0] <= best + tie:
            count += 1
            for c in range(3):
                sums[0, c] += one[1][0, c]
                sums[1, c] += one[2][0, c]
                sums[2, c] += one[3][0, c]
    if count > 1:
        for c in range(3):
            point_a[row, c], point_b[row, c] = sums[0, c] / count, sums[1, c] / count
            point[row, c] = sums[2, c] / count


@compiled.jit
def _rows(tables, centre, half, spans, t, r, limit, ties, out):
    """:func:`_row` over every pose (serial); row k's bodies are ``spans[k]`` (a single span:
    every row's), its tie slack ``ties[k]`` (m)."""
    work = np.empty(scratch_slots(int(np.max(np.diff(tables[1])))))
    pairs = 1
    for k in range(spans.shape[0]):
        pairs = max(pairs, (spans[k, 1] - spans[k, 0]) * (spans[k, 3] - spans[k, 2]))
    bounds, order_buf = np.empty(pairs), np.empty(pairs, np.int64)
    one = (np.empty(1), np.empty((1, 3)), np.empty((1, 3)), np.empty((1, 3)), np.empty((1, 3)))
    for row in range(t.shape[0]):
        k = row if spans.shape[0] > 1 else 0
        _row(tables, centre, half, spans[k], t[row], r[row], limit, ties[k], work, bounds,
             order_buf, one, out, row)


def body_gaps(table_a, table_b, position_a, quaternion_a, position_b, quaternion_b,
              limit: float = np.inf) -> BodyGaps:
    """The gaps of N poses of two bodies (body tables of
    :mod:`impactnet.models.compound.body_table`, or :func:`box_bodies` of one box; poses (n, 3)
    metres, (n, 4) unit quaternions); pairs farther apart than ``limit`` (m) answer an infinite
    distance and no parts."""
    first = np.zeros(1, np.int64)
    return bodies_gaps([table_a, table_b], first, first + 1, position_a, quaternion_a,
                       position_b, quaternion_b, limit)


def _joined(parts: list[PartTables]) -> tuple:
    """(flat hull tables, bounds' centres, half extents, each body's first hull (B + 1,)) of
    several :class:`PartTables`, hull after hull."""
    first = np.concatenate([[0], np.cumsum(np.concatenate([p.hulls for p in parts]))])
    corners = np.concatenate([[0], np.cumsum([int(p.tables.vertex_start[-1]) for p in parts])])
    vertex_start = np.concatenate([p.tables.vertex_start[:-1] + corners[k]
                                   for k, p in enumerate(parts)] + [corners[-1:]])
    flat = (np.ascontiguousarray(np.concatenate([p.tables.vertices for p in parts]),
                                 np.float64),
            np.ascontiguousarray(vertex_start, np.int64),
            np.ascontiguousarray(np.concatenate([p.tables.hull_size for p in parts]),
                                 np.float64))
    centre = np.ascontiguousarray(np.concatenate([p.centre for p in parts]), np.float64)
    half = np.ascontiguousarray(np.concatenate([p.half for p in parts]), np.float64)
    return flat, centre, half, first.astype(np.int64)


def bodies_gaps(bodies, body_a, body_b, position_a, quaternion_a, position_b, quaternion_b,
                limit: float = np.inf) -> BodyGaps:
    """The gaps of N poses, row k between bodies ``body_a[k]`` and ``body_b[k]`` of
    ``bodies`` (body tables, one body each, or :class:`PartTables` of one or more, such as
    :func:`box_bodies`: the bodies are numbered in that order; ``body_a``, ``body_b``: (n,) or
    (1,) indices) in one compiled call whatever the number of distinct bodies, so that a batch
    of many box sizes against one container costs its rows, not a call per size. Answers as
    :func:`body_gaps`; each row's tie slack is its own two bodies' (their largest part's half
    extent)."""
    parts = [_body_parts(b) for b in bodies]
    flat, centre, half, first = _joined(parts)
    body_a = np.asarray(body_a, np.int64).reshape(-1)
    body_b = np.asarray(body_b, np.int64).reshape(-1)
    spans = np.ascontiguousarray(np.stack(np.broadcast_arrays(
        first[body_a], first[body_a + 1], first[body_b], first[body_b + 1]), axis=1))
    widest = int(((spans[:, 1] - spans[:, 0]) * (spans[:, 3] - spans[:, 2])).max())
    if widest > MAX_PART_PAIRS:
        raise ValueError(f"{widest} part pairs: more than {MAX_PART_PAIRS}")
    largest = np.maximum.reduceat(half.max(axis=1), first[:-1])  # (B,) per body
    ties = np.ascontiguousarray(SUPPORT_REL * np.maximum(*np.broadcast_arrays(
        largest[body_a], largest[body_b])), np.float64)
    rot_a, t, r = _relative(position_a, quaternion_a, position_b, quaternion_b)
    n = len(t)
    out = (np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
           np.empty((n, 3)), np.empty(n, np.int64), np.empty(n, np.int64))
    for lo, hi in compiled.chunks(n):
        rows = slice(lo, hi) if len(spans) > 1 else slice(0, 1)
        _rows(flat, centre, half, spans[rows], t[lo:hi], r[lo:hi], float(limit), ties[rows],
              tuple(o[lo:hi] for o in out))
    return _world(position_a, rot_a, *out)


def _relative(position_a, quaternion_a, position_b, quaternion_b):
    """(R_A (n, 3, 3), t (n, 3), R (n, 3, 3)): B's pose in A's frame."""
    rot_a, rot_b = quaternion_to_matrix(quaternion_a), quaternion_to_matrix(quaternion_b)
    ra_t = rot_a.transpose(0, 2, 1)
    t = np.ascontiguousarray(np.einsum("nij,nj->ni", ra_t, position_b - position_a))
    return rot_a, t, np.ascontiguousarray(ra_t @ rot_b)


def _world(position_a, rot_a, distance, pa, pb, mid, direction, part_a, part_b) -> BodyGaps:
    world = [position_a + np.einsum("nij,nj->ni", rot_a, v) for v in (pa, pb, mid)]
    return BodyGaps(distance, *world, np.einsum("nij,nj->ni", rot_a, direction), part_a,
                    part_b)


@compiled.on_warm_up
def _warm_up() -> None:
    from impactnet.models.compound.body_table import TransientParts, body_table
    from impactnet.models.compound.parts import BoxPart

    box = body_table(TransientParts((BoxPart("box", (1.0, 1.0, 1.0)),)))
    level = np.array([[1.0, 0.0, 0.0, 0.0]])
    body_gaps(box, box, np.zeros((1, 3)), level, np.array([[0.0, 0.0, 2.0]]), level)
