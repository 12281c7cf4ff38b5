"""The broadphase over bodies: which pairs of N bodies may touch or lie within a margin,
compiled (sweep and prune), n log n plus the pairs it finds.

Stages, all in one kernel call:

1. **World bounds**: each body's bounds are an oriented box (its envelope in its own frame,
   centre ``c`` and half extents ``h``, placed by its pose); its axis-aligned world bounds are
   ``p + R c +- |R| h``, grown by half the margin on every side, so that two bodies within the
   margin of each other have overlapping bounds.
2. **Sweep**: the bounds are sorted by their low end along the world axis on which the bodies'
   centres spread most; walking that order, a body is tested against the ones after it until
   their low end passes its high end (the only ones whose intervals can overlap on that axis),
   then on the two other axes.
3. **Filter**: a pair is kept when ``(type_a & affinity_b) | (type_b & affinity_a)`` is not zero
   (MuJoCo's contype / conaffinity rule; every body 1/1 by default) and the two are not both
   static (two bodies of the registered world never touch anything new).

The pairs come back as ``(k, 2)`` indices, each with the lower index first, sorted.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import compiled

#: Added to the bounds' half extents (x their size, dimensionless) so that a pair touching
#: within round-off is never culled (the narrowphase decides it).
BOUNDS_SLACK_REL = 1e-9
#: Pairs a sweep can hold before it is run again with more room (grown x4 each time).
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


@compiled.jit
def sweep(lo, hi, types, affinities, static, out):
    """Stages 2-3: the pairs whose bounds overlap and whose filter lets them touch, written
    into ``out`` (capacity (m, 2)); returns how many there are (more than ``m``: run again
    with more room)."""
    axis = _sweep_axis(lo, hi)
    order = np.argsort(lo[:, axis], kind="mergesort")
    count = 0
    n = lo.shape[0]
    for k in range(n):
        i = order[k]
        for m in range(k + 1, n):
            j = order[m]
            if lo[j, axis] > hi[i, axis]:
                break
            if static[i] and static[j]:
                continue
            if (types[i] & affinities[j]) == 0 and (types[j] & affinities[i]) == 0:
                continue
            apart = False
            for r in range(3):
                if lo[j, r] > hi[i, r] or lo[i, r] > hi[j, r]:
                    apart = True
                    break
            if apart:
                continue
            if count < out.shape[0]:
                out[count, 0] = min(i, j)
                out[count, 1] = max(i, j)
            count += 1
    return count


def body_pairs(centre, half, position, rotation, margin=0.0, types=None, affinities=None,
               static=None) -> np.ndarray:
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
    out = np.empty((INITIAL_PAIRS, 2), np.int64)
    count = sweep(lo, hi, types, affinities, static, out)
    while count > len(out):
        out = np.empty((4 * count, 2), np.int64)
        count = sweep(lo, hi, types, affinities, static, out)
    pairs = out[:count]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


@compiled.on_warm_up
def _warm_up() -> None:
    eye = np.broadcast_to(np.eye(3), (3, 3, 3))
    body_pairs(np.zeros((3, 3)), np.ones((3, 3)), [[0, 0, 0], [1.5, 0, 0], [9, 0, 0]], eye)
