"""Stage 4 of the compiled compound pipeline: the body-level summary of one pose's part contacts
(docs/design.md, :mod:`impactnet.models.compound.summary`).

* the deepest part contact (the first of equal depths) sets ``depth`` and the reference normal;
* the cluster: the part contacts whose normals lie within
  :data:`~impactnet.models.compound.summary.CLUSTER_ANGLE_DEG` of it (the deepest included);
* the weights: each cluster member's pressure integral ``int (d + tau) dA``; a cluster of
  edge-edge contacts only (zero area, so zero weight) weighs its members equally;
* ``normal``: the weighted normals summed and normalised; ``point``: the weighted mean of the
  points.

The sums are the NumPy summary's: ``np.bincount`` adds the rows in order from 0, the angle is
``atan2(|n x r|, n . r)`` with ``np.einsum``'s order of the dot product (the arctangent is
libm's, NumPy's own may differ by an ulp: that matters only at exactly 10 degrees).
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compiled import jit

#: Part contacts whose normals lie within this angle (degrees) of the deepest contact's normal
#: push the same way and are summed: far wider than a stack's tilt (milliradians), far
#: narrower than the 90 degrees between a guide's side and its chamfer or the 180 degrees
#: between the two sides of an aperture.
CLUSTER_ANGLE_DEG = 10.0


@jit
def _in_cluster(normal, r, reference):
    """Whether row r's normal lies within the cluster's angle of the reference (3-tuple), as
    ``angle_deg`` measures it."""
    n0, n1, n2 = normal[r, 0], normal[r, 1], normal[r, 2]
    c0 = n1 * reference[2] - n2 * reference[1]
    c1 = n2 * reference[0] - n0 * reference[2]
    c2 = n0 * reference[1] - n1 * reference[0]
    cross = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    dot = (n0 * reference[0] + n2 * reference[2]) + n1 * reference[1]
    return math.degrees(math.atan2(cross, dot)) <= CLUSTER_ANGLE_DEG


@jit
def pose_summary(rows, count, depth, normal, point, pressure, out, p):
    """The summary of pose p from its part contacts ``rows[:count]`` (rows of the contact
    arrays, in order) into ``out`` (colliding, normal, depth, point, cluster size: arrays of
    the poses) at p."""
    colliding_out, normal_out, depth_out, point_out, size_out = out
    colliding_out[p] = count > 0
    for k in range(3):
        normal_out[p, k], point_out[p, k] = 0.0, 0.0
    depth_out[p], size_out[p] = 0.0, 0
    if count == 0:
        return
    deepest = rows[0]
    for s in range(1, count):
        if depth[rows[s]] > depth[deepest]:
            deepest = rows[s]
    reference = (normal[deepest, 0], normal[deepest, 1], normal[deepest, 2])
    total, size = 0.0, 0
    for s in range(count):
        if _in_cluster(normal, rows[s], reference):
            total += pressure[rows[s]]
            size += 1
    equal = not total > 0.0  # edge-edge only: equal weights
    total = 0.0
    summed = (0.0, 0.0, 0.0)
    pushed = (0.0, 0.0, 0.0)
    for s in range(count):
        r = rows[s]
        inside = _in_cluster(normal, r, reference)
        weight = (1.0 if equal else pressure[r]) if inside else 0.0
        total += weight
        summed = (summed[0] + weight * point[r, 0], summed[1] + weight * point[r, 1],
                  summed[2] + weight * point[r, 2])
        pushed = (pushed[0] + weight * normal[r, 0], pushed[1] + weight * normal[r, 1],
                  pushed[2] + weight * normal[r, 2])
    safe = total if total > 0.0 else 1.0
    length = math.sqrt(pushed[0] * pushed[0] + pushed[1] * pushed[1] + pushed[2] * pushed[2])
    length = length if length > 0.0 else 1.0
    for k in range(3):
        point_out[p, k] = summed[k] / safe
        normal_out[p, k] = pushed[k] / length
    depth_out[p], size_out[p] = depth[deepest], size


@jit
def summaries(offsets, depth, normal, point, pressure):
    """The summary of every pose of pose-major part contacts (pose p's rows
    ``offsets[p]:offsets[p + 1]``): colliding, normal, depth, point, cluster size."""
    n = offsets.shape[0] - 1
    out = (np.empty(n, np.bool_), np.empty((n, 3)), np.empty(n), np.empty((n, 3)),
           np.empty(n, np.int64))
    rows = np.arange(offsets[n])
    for p in range(n):
        pose_summary(rows[offsets[p]:], offsets[p + 1] - offsets[p], depth, normal, point,
                     pressure, out, p)
    return out
