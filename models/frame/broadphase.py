"""The broadphase over bodies: which pairs of N bodies may touch or lie within a margin,
compiled (sweep and prune).

Stages (two kernels and a NumPy sort):

1. **World bounds**: each body's bounds are an oriented box (its envelope in its own frame,
   centre ``c`` and half extents ``h``, placed by its pose); its axis-aligned world bounds are
   ``p + R c +- |R| h``, grown by half the margin on every side, so that two bodies within the
   margin of each other have overlapping bounds.
2. **Sweep**: the bounds are sorted by their low end along the world axis on which the bodies'
   centres spread most; walking that order, each body is tested against the ones after it
   until their low end passes its high end (the only ones whose intervals can overlap on that
   axis), then on the two other axes; a static body only against the moving ones.
3. **Filter**: a pair is kept when ``(type_a & affinity_b) | (type_b & affinity_a)`` is not zero
   (MuJoCo's contype / conaffinity rule; every body 1/1 by default) and the two are not both
   static (two bodies of the registered world never touch anything new).

The cost is the sort (n log n) and the walks: the pairs of moving bodies whose bounds overlap
on the sweep axis, which is more than the pairs found where many bodies share an interval of
that axis (a yard of many rows and columns, swept along its columns: the walk grows as
n^1.5 there; docs/benchmarks/frame.md), and only the moving bodies' neighbourhoods when the
frame has a static world. The pairs come back as ``(k, 2)`` indices, each with the lower
index first, sorted.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import compiled

#: Added to the bounds' half extents (x their size, dimensionless) so that a pair touching
#: within round-off is never culled (the narrowphase decides it).
BOUNDS_SLACK_REL = 1e-9
#: Pairs the sweep has room for at first (the room doubles as they come).
INITIAL_PAIRS = 4096


@compiled.jit
def world_bounds(centre, half, position, rotation, margin, lo, hi):
    """Stage 1: axis-aligned world bounds (n, 3) of oriented boxes (module docstring).

    Parameters
    ----------
    centre, half : ndarray, shape (n, 3)
        The boxes' centres and half extents in their bodies' frames (metres).
    position : ndarray, shape (n, 3)
    rotation : ndarray, shape (n, 3, 3)
        The bodies' poses (``v_world = R v_body + p``).
    margin : float
        Metres; every box grows by half of it on every side.
    lo, hi : ndarray, shape (n, 3)
        Written: the world bounds.
    """
    for i in range(position.shape[0]):
        for r in range(3):
            mid = position[i, r]
            reach = 0.0
            for c in range(3):
                mid += rotation[i, r, c] * centre[i, c]
                reach += abs(rotation[i, r, c]) * half[i, c]
            reach = reach * (1.0 + BOUNDS_SLACK_REL) + 0.5 * margin
            lo[i, r] = mid - reach
            hi[i, r] = mid + reach


@compiled.jit
def _sweep_axis(lo, hi):
    """The world axis on which the bounds' centres spread most."""
    best, axis = -1.0, 0
    n = lo.shape[0]
    for r in range(3):
        mean = 0.0
        for i in range(n):
            mean += 0.5 * (lo[i, r] + hi[i, r])
        mean /= max(n, 1)
        spread = 0.0
        for i in range(n):
            d = 0.5 * (lo[i, r] + hi[i, r]) - mean
            spread += d * d
        if spread > best:
            best, axis = spread, r
    return axis


class TooManyBodyPairs(ValueError):
    """The bodies' bounds overlap in more than ``cap`` pairs (``count`` found before the stop)."""

    def __init__(self, count: int, cap: int) -> None:
        self.count, self.cap = count, cap
        super().__init__(f"more than {cap} pairs of bodies may touch ({count} found before "
                         f"the sweep stopped)")


@compiled.jit
def _meets(k, m, kind, affinity, box_lo, box_hi):
    """Whether bodies k and m may touch (their filter bits) and their bounds overlap."""
    if (kind[k] & affinity[m]) == 0 and (kind[m] & affinity[k]) == 0:
        return False
    return not (box_lo[m, 0] > box_hi[k, 0] or box_lo[k, 0] > box_hi[m, 0]
                or box_lo[m, 1] > box_hi[k, 1] or box_lo[k, 1] > box_hi[m, 1]
                or box_lo[m, 2] > box_hi[k, 2] or box_lo[k, 2] > box_hi[m, 2])


@compiled.jit
def _grown(out, count):
    """``out`` (m, 2) with twice the room, its first ``count`` rows kept."""
    bigger = np.empty((2 * out.shape[0], 2), np.int64)
    bigger[:count] = out[:count]
    return bigger


@compiled.jit
def _gathered(lo, hi, order, axis, types, affinities, static):
    """The bounds and filters in sweep order: ``start``, ``end`` (n,) on the sweep axis,
    ``box_lo``, ``box_hi`` (n, 3), ``kind``, ``affinity``, ``fixed`` (n,)."""
    n = lo.shape[0]
    start, end = np.empty(n), np.empty(n)
    box_lo, box_hi = np.empty((n, 3)), np.empty((n, 3))
    kind, affinity = np.empty(n, np.int64), np.empty(n, np.int64)
    fixed = np.empty(n, np.bool_)
    for k in range(n):
        i = order[k]
        start[k], end[k] = lo[i, axis], hi[i, axis]
        kind[k], affinity[k], fixed[k] = types[i], affinities[i], static[i]
        for r in range(3):
            box_lo[k, r], box_hi[k, r] = lo[i, r], hi[i, r]
    return start, end, box_lo, box_hi, kind, affinity, fixed


@compiled.jit
def sweep(lo, hi, order, axis, types, affinities, static, limit, room):
    """Stages 2-3: the pairs whose bounds overlap and whose filter lets them touch, as
    ``(pairs (k, 2), k)``, stopping as soon as there are more than ``limit`` (then ``k`` is
    ``limit + 1``). ``order`` (n,): the bodies by the low end of their bounds on ``axis``
    (sorted by NumPy, several times faster than numba's sort); ``room``: the pairs there is
    room for at first (>= 1), doubled as they come (one pass, whatever their number).

    Each body walks forward from its place in that order until the low ends pass its high
    end: a body that moved over every body after it, a static one over the moving bodies
    after it only (from a binary search among them), since two static bodies never pair.
    Without a static world that is the plain sweep; with one, the walks are the moving bodies'
    neighbourhoods, not the world's. The bounds are gathered in sweep order first, so that the
    walks read memory in order. (The two walks share their test, written out in each: a call
    per candidate costs more than the test.)"""
    start, end, box_lo, box_hi, kind, affinity, fixed = _gathered(lo, hi, order, axis, types,
                                                                  affinities, static)
    n = start.shape[0]
    moving = np.flatnonzero(~fixed)  # sweep positions of the bodies that moved
    out = np.empty((room, 2), np.int64)
    count = 0
    for k in moving:  # a moving body: every body after it
        for m in range(k + 1, n):
            if start[m] > end[k]:
                break
            if not _meets(k, m, kind, affinity, box_lo, box_hi):
                continue
            if count == out.shape[0]:
                out = _grown(out, count)
            out[count, 0], out[count, 1] = min(order[k], order[m]), max(order[k], order[m])
            count += 1
            if count > limit:
                return out[:count], count
    for k in np.flatnonzero(fixed):  # a static body: the moving bodies after it
        for q in range(np.searchsorted(moving, k + 1), moving.shape[0]):
            m = moving[q]
            if start[m] > end[k]:
                break
            if not _meets(k, m, kind, affinity, box_lo, box_hi):
                continue
            if count == out.shape[0]:
                out = _grown(out, count)
            out[count, 0], out[count, 1] = min(order[k], order[m]), max(order[k], order[m])
            count += 1
            if count > limit:
                return out[:count], count
    return out[:count], count


def body_pairs(centre, half, position, rotation, margin=0.0, types=None, affinities=None,
               static=None, max_pairs: int | None = None) -> np.ndarray:
    """The pairs of bodies that may touch or lie within ``margin`` (module docstring).

    Parameters
    ----------
    centre, half : array_like, shape (n, 3)
        Each body's envelope in its own frame (metres).
    position : array_like, shape (n, 3)
    rotation : array_like, shape (n, 3, 3)
        The bodies' poses.
    margin : float
        Metres (>= 0).
    types, affinities : array_like of int, shape (n,), optional
        Bit masks of the filter (default 1 each: every pair).
    static : array_like of bool, shape (n,), optional
        Bodies of a registered static world (default none).
    max_pairs : int, optional
        Raise :class:`TooManyBodyPairs` past this many pairs (the sweep stops there).

    Returns
    -------
    ndarray of int64, shape (k, 2)
        Index pairs (lower first), sorted.
    """
    position = np.ascontiguousarray(position, np.float64)
    n = len(position)
    ones = np.ones(n, np.int64)
    types = ones if types is None else np.ascontiguousarray(types, np.int64)
    affinities = ones if affinities is None else np.ascontiguousarray(affinities, np.int64)
    static = np.zeros(n, np.bool_) if static is None else np.ascontiguousarray(static, np.bool_)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    world_bounds(np.ascontiguousarray(centre, np.float64), np.ascontiguousarray(half, np.float64),
                 position, np.ascontiguousarray(rotation, np.float64), float(margin), lo, hi)
    limit = np.iinfo(np.int64).max if max_pairs is None else int(max_pairs)
    room = max(1, min(INITIAL_PAIRS, limit + 1))
    axis = _sweep_axis(lo, hi)
    order = np.argsort(lo[:, axis], kind="stable")
    pairs, count = sweep(lo, hi, order, axis, types, affinities, static, limit, room)
    if count > limit:
        raise TooManyBodyPairs(count, limit)
    key = np.sort(pairs[:, 0] * max(n, 1) + pairs[:, 1])  # (lower, higher) in order
    return np.stack([key // max(n, 1), key % max(n, 1)], axis=1)


@compiled.on_warm_up
def _warm_up() -> None:
    eye = np.broadcast_to(np.eye(3), (3, 3, 3))
    body_pairs(np.zeros((3, 3)), np.ones((3, 3)), [[0, 0, 0], [1.5, 0, 0], [9, 0, 0]], eye)
