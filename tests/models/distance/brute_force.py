"""Test and bench helper: the exact alternative compiled, the minimum over vertex-face and
edge-edge pairs (the reference's method, tests/models/distance/reference.py) as a numba row
loop, to choose the served algorithm by measurement (bench_gap.py). Distance only.

Not a test module and not a served path: per row it visits every feature pair (a box against
a 128-sided frustum: 2,576 vertex-face and 4,608 edge-edge pairs), where GJK visits a few
support points per iteration.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compiled import jit
from tests.models.distance.reference import features


@jit
def _dot(x, i, y, j):
    return x[i, 0] * y[j, 0] + x[i, 1] * y[j, 1] + x[i, 2] * y[j, 2]


@jit
def _segments(ends_a, i, ends_b, j):
    """Distance between edge ``i`` of ``ends_a`` (E, 2, 3) and edge ``j`` of ``ends_b``
    (Ericson 5.1.9, scalars)."""
    p, q, a, b = ends_a[i, 0], ends_a[i, 1], ends_b[j, 0], ends_b[j, 1]
    d1x, d1y, d1z = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    d2x, d2y, d2z = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    rx, ry, rz = p[0] - a[0], p[1] - a[1], p[2] - a[2]
    aa, ee = d1x * d1x + d1y * d1y + d1z * d1z, d2x * d2x + d2y * d2y + d2z * d2z
    bb, cc = d1x * d2x + d1y * d2y + d1z * d2z, d1x * rx + d1y * ry + d1z * rz
    ff = d2x * rx + d2y * ry + d2z * rz
    denom = aa * ee - bb * bb
    s = min(1.0, max(0.0, (bb * ff - cc * ee) / denom)) if denom > 0.0 else 0.0
    t = (bb * s + ff) / ee
    if t < 0.0:
        t, s = 0.0, min(1.0, max(0.0, -cc / aa))
    elif t > 1.0:
        t, s = 1.0, min(1.0, max(0.0, (bb - cc) / aa))
    gx, gy, gz = rx + s * d1x - t * d2x, ry + s * d1y - t * d2y, rz + s * d1z - t * d2z
    return math.sqrt(gx * gx + gy * gy + gz * gz)


@jit
def _over_faces(points, normals, offsets, sides, side_offsets):
    """The least distance of ``points`` (k, 3) to the faces they stand over (inf if none)."""
    best = np.inf
    for i in range(points.shape[0]):
        for f in range(normals.shape[0]):
            over = True
            for m in range(sides.shape[1]):
                if (sides[f, m, 0] * points[i, 0] + sides[f, m, 1] * points[i, 1]
                        + sides[f, m, 2] * points[i, 2] < side_offsets[f, m]):
                    over = False
                    break
            if over:
                best = min(best, abs(_dot(normals, f, points, i) - offsets[f]))
    return best


@jit
def _placed(points, t, r, inverse):
    """``points`` (k, 3) by ``r`` and ``t`` (or back by them, ``inverse``)."""
    out = np.empty_like(points)
    for i in range(points.shape[0]):
        for c in range(3):
            if inverse:
                out[i, c] = ((points[i, 0] - t[0]) * r[0, c] + (points[i, 1] - t[1]) * r[1, c]
                             + (points[i, 2] - t[2]) * r[2, c])
            else:
                out[i, c] = (t[c] + r[c, 0] * points[i, 0] + r[c, 1] * points[i, 1]
                             + r[c, 2] * points[i, 2])
    return out


@jit
def brute_gaps(fa, fb, t, r, out):
    """``out[i]``: the distance at relative pose ``t[i]`` (3,), ``r[i]`` (3, 3) (B in A's
    frame); ``fa``, ``fb``: (vertices, edges (E, 2, 3), normals, offsets, sides, side
    offsets)."""
    ends = fb[1].shape[0]
    for i in range(t.shape[0]):
        best = min(_over_faces(_placed(fa[0], t[i], r[i], True), fb[2], fb[3], fb[4], fb[5]),
                   _over_faces(_placed(fb[0], t[i], r[i], False), fa[2], fa[3], fa[4], fa[5]))
        eb = _placed(fb[1].reshape(2 * ends, 3), t[i], r[i], False).reshape(ends, 2, 3)
        for j in range(fa[1].shape[0]):
            for k in range(ends):
                best = min(best, _segments(fa[1], j, eb, k))
        out[i] = best


def brute_tables(hull):
    """The feature tuple of :func:`brute_gaps` for a hull (contiguous arrays)."""
    f = features(hull)
    return tuple(np.ascontiguousarray(x) for x in (f.vertices, f.edges, f.normals, f.offsets,
                                                   f.side_normals, f.side_offsets))
