"""Closed-form clip of the incident quad against the reference rectangle, for m face contacts.

Part of stage 3 of the exact solver (see :mod:`impactnet.models.box.manifold`, which explains the
geometry).
The vertices of the intersection of a convex quad and an axis-aligned rectangle are among 24
candidates, in this fixed order:

* 0-3: the quad's vertices inside the rectangle (snapped onto it);
* 4-7: the rectangle's corners inside the quad, unless on a quad vertex;
* 8-23: the crossing of quad edge e (from vertex e to e + 1) with rectangle line l (u = +h_u,
  u = -h_u, w = +h_w, w = -h_w), at index ``8 + 4 e + l``, unless at an end of either.

Candidates above the reference plane (depth below -tol) are dropped. The manifold is the
surviving candidates, deepest first, ties in candidate order (a stable sort, as the scalar
path's ``list.sort``), at most :data:`impactnet.models.contacts.MAX_MANIFOLD_POINTS` of them.

Columns: each quantity is an (m,) array (see :mod:`impactnet.models.box.local_frame`); the
candidates of the
m contacts are a (4, 24, m) array: u, w, depth (metres) and the sort key (-depth, or +inf for
a dropped candidate). Every formula follows :func:`impactnet.models.box.exact_one._clip` term by
term,
except in two tolerance tests: edge lengths are ``sqrt(x*x + y*y)``, not ``hypot``, and a
corner's distance to a quad vertex is compared squared (``gap**2 > tol**2``).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.contacts import MAX_MANIFOLD_POINTS

#: Number of clip candidates: 4 quad vertices, 4 rectangle corners, 4 x 4 edge crossings.
N_CANDIDATES = 24
#: Rows of the candidate array.
U, W, DEPTH, KEY = range(4)
#: Rectangle corners as signs along u and along w (columns), in the quad's cyclic order.
_CORNER_U = np.array([1.0, -1.0, -1.0, 1.0])[:, None]
_CORNER_W = np.array([1.0, 1.0, -1.0, -1.0])[:, None]
#: The vertex after each quad vertex, in cyclic order.
_NEXT_VERTEX = [1, 2, 3, 0]


def _vertex_candidates(out, quad_u, quad_w, depth, half_u, half_w, tol):
    """Candidates 0-3: quad vertices inside the rectangle, clamped onto it."""
    np.minimum(np.maximum(quad_u, -half_u), half_u, out=out[U, 0:4])
    np.minimum(np.maximum(quad_w, -half_w), half_w, out=out[W, 0:4])
    out[DEPTH, 0:4] = depth
    valid = (np.abs(quad_u) <= half_u + tol) & (np.abs(quad_w) <= half_w + tol) & (
        depth >= -tol)
    out[KEY, 0:4] = np.where(valid, -depth, np.inf)


def _corner_candidates(out, quad_u, quad_w, depth, half_u, half_w, tol):
    """Candidates 4-7: rectangle corners inside the quad (a parallelogram), off its vertices."""
    cu = 0.25 * (quad_u[0] + quad_u[1] + quad_u[2] + quad_u[3])
    cw = 0.25 * (quad_w[0] + quad_w[1] + quad_w[2] + quad_w[3])
    a0, a1 = 0.5 * (quad_u[0] - quad_u[1]), 0.5 * (quad_w[0] - quad_w[1])
    b0, b1 = 0.5 * (quad_u[1] - quad_u[2]), 0.5 * (quad_w[1] - quad_w[2])
    det = a0 * b1 - a1 * b0
    len_a, len_b = np.sqrt(a0 * a0 + a1 * a1), np.sqrt(b0 * b0 + b1 * b1)
    d_c = 0.25 * (depth[0] + depth[1] + depth[2] + depth[3])
    d_a, d_b = 0.5 * (depth[0] - depth[1]), 0.5 * (depth[1] - depth[2])
    corner_u, corner_w = _CORNER_U * half_u, _CORNER_W * half_w  # (4, m)
    ru, rw = corner_u - cu, corner_w - cw
    alpha = (ru * b1 - rw * b0) / det
    beta = (a0 * rw - a1 * ru) / det
    d = d_c + alpha * d_a + beta * d_b
    valid = (((np.abs(alpha) - 1.0) * len_a <= tol) & ((np.abs(beta) - 1.0) * len_b <= tol)
             & (d >= -tol))
    # A corner on a quad vertex (squared distance within tol^2) is that vertex; tested only
    # for the corners that survive the other tests.
    hit = np.flatnonzero(valid)
    if hit.size:
        row = hit % len(tol)
        gap2 = ((np.take(corner_u, hit) - np.take(quad_u, row, axis=1)) ** 2
                + (np.take(corner_w, hit) - np.take(quad_w, row, axis=1)) ** 2)
        valid.reshape(-1)[hit] = (gap2 > (tol * tol)[row]).all(axis=0)
    out[U, 4:8], out[W, 4:8], out[DEPTH, 4:8] = corner_u, corner_w, d
    out[KEY, 4:8] = np.where(valid, -d, np.inf)


def _crossing_candidates(out, quad_u, quad_w, depth, half_u, half_w, tol):
    """Candidates 8-23: quad edges crossing the interior of a rectangle edge.

    Quad edge e runs from vertex e to e + 1; candidate ``8 + 4 e + l`` is its crossing with
    line l (u = +h_u, u = -h_u, w = +h_w, w = -h_w). Arrays are (4 edges, 2 lines, m) per
    crossing coordinate, written straight into ``out``.
    """
    quad = (quad_u, quad_w)
    delta = (quad_u[_NEXT_VERTEX] - quad_u, quad_w[_NEXT_VERTEX] - quad_w)
    d_delta = (depth[_NEXT_VERTEX] - depth)[:, None]
    edge_len = np.sqrt(delta[0] * delta[0] + delta[1] * delta[1])[:, None]
    floor = -tol
    crossings = out[:, 8:].reshape(4, 4, 4, -1)  # (row, edge, line, m)
    for coord, half, other_half in ((0, half_u, half_w), (1, half_w, half_u)):
        lines = slice(2 * coord, 2 * coord + 2)
        value = crossings[U if coord == 0 else W, :, lines]
        value[:] = np.array([half, -half])  # the two lines
        moves = delta[coord] != 0.0
        step = delta[coord] if moves.all() else np.where(moves, delta[coord], 1.0)
        tau = (value - quad[coord][:, None]) / step[:, None]
        other = crossings[W if coord == 0 else U, :, lines]
        np.add(quad[1 - coord][:, None], tau * delta[1 - coord][:, None], out=other)
        d = np.add(depth[:, None], tau * d_delta, out=crossings[DEPTH, :, lines])
        valid = ((tau * edge_len > tol) & ((1.0 - tau) * edge_len > tol)
                 & (np.abs(other) < other_half - tol) & (d >= floor))
        if step is not delta[coord]:
            valid &= moves[:, None]
        crossings[KEY, :, lines] = np.where(valid, -d, np.inf)


def clip_candidates(quad_u, quad_w, depth, half_u, half_w, tol) -> np.ndarray:
    """The 24 clip candidates of m incident quads against their reference rectangles.

    Parameters
    ----------
    quad_u, quad_w : ndarray, shape (4, m)
        Incident quad vertices projected on the reference plane (metres), cyclic order.
    depth : ndarray, shape (4, m)
        Penetration depth of the quad vertices below the reference plane (metres).
    half_u, half_w : ndarray, shape (m,)
        Reference rectangle half-extents (metres).
    tol : ndarray, shape (m,)
        Snap tolerance (metres).

    Returns
    -------
    ndarray, shape (4, 24, m)
        Rows u, w, depth (metres) and key (-depth, +inf for dropped candidates).
    """
    out = np.empty((4, N_CANDIDATES, len(tol)))
    _vertex_candidates(out, quad_u, quad_w, depth, half_u, half_w, tol)
    _corner_candidates(out, quad_u, quad_w, depth, half_u, half_w, tol)
    _crossing_candidates(out, quad_u, quad_w, depth, half_u, half_w, tol)
    return out


def manifold_order(candidates: np.ndarray):
    """The surviving candidates, deepest first, stable in candidate order, as entries.

    The survivors of each row are packed in candidate order into a (m, w) table (w = the
    most survivors of any row), padded with +inf keys, and sorted there with a stable
    argsort: a short row sorts much faster than the 24 candidates.

    Parameters
    ----------
    candidates : ndarray, shape (4, 24, m)
        From :func:`clip_candidates`.

    Returns
    -------
    rows, slots : ndarray of int, shape (E,)
        Row and manifold slot (0 = deepest) of each of the E manifold points, by row, then
        slot; a row has ``count`` entries.
    values : ndarray, shape (3, E)
        u, w and depth of each entry (metres).
    count : ndarray of int8, shape (m,)
        Number of manifold points, at most :data:`MAX_MANIFOLD_POINTS`.
    """
    key = candidates[KEY]
    m = key.shape[1]
    survivor = np.flatnonzero(np.ascontiguousarray((key < np.inf).T))  # by row, candidate
    row, cand = np.divmod(survivor, N_CANDIDATES)
    survivors = np.bincount(row, minlength=m)
    width = max(int(survivors.max()) if m else 0, 1)
    first = np.cumsum(survivors) - survivors  # first survivor of each row
    first_of_row = np.take(first, row)
    slot = np.arange(len(row)) - first_of_row
    packed = np.full(m * width, np.inf)
    at = row * width + slot
    packed[at] = np.take(key.reshape(-1), cand * m + row)
    order = np.argsort(packed.reshape(m, width), axis=1, kind="stable")
    count = np.minimum(survivors, MAX_MANIFOLD_POINTS).astype(np.int8)
    if width > MAX_MANIFOLD_POINTS:  # some row keeps only its deepest points: fewer entries
        row = np.repeat(np.arange(m), count)
        slot = np.arange(len(row)) - np.repeat(np.cumsum(count, dtype=np.intp) - count, count)
        first_of_row, at = np.take(first, row), row * width + slot
    chosen = first_of_row + np.take(order, at)  # survivor index of each manifold point
    flat = np.take(cand, chosen) * m + row
    values = np.take(candidates[:DEPTH + 1].reshape(DEPTH + 1, -1), flat, axis=1)
    return row, slot, values, count
