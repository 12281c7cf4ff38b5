"""The committee's region classifier: the exact solver's own decision, without the clipping.

The region of a contact (contact type, feature of A, feature of B) is decided at tolerance
scale: on about a quarter of first-contact poses the separating-axis margin is below 1e-4 of
the pair's size, and the tie rules (1e-12 of the size) pick the axis and the incident feature
(docs/classifier_study.md). A classifier that is to agree with the exact solver there must
repeat its float64 arithmetic, so it does, and costs less than a learned one would:

1. the separating-axis test and its tie rule give "none", the axis, the depth and the normal,
   exactly;
2. for a face axis, the incident face's four vertex depths name the incident feature; for a
   cross axis, the two supporting edges

(both the solver's own row kernel: :func:`impactnet.models.box.kernel_views.decision_rows`, on
the one row). What is left for the learned experts is the point, whose exact computation (the
centre of pressure of the clipped footprint, :mod:`impactnet.models.box.kernel_pressure`) is the
expensive part; the labeller gives its *unclipped point* (:func:`face_point`) as their baseline.

:func:`label` is the row function, compiled, which the predictors' kernels call for one pair
and for every row of a batch (:mod:`impactnet.models.learned.kernel_pair`); :func:`label_block`
and :func:`unclipped_points` run it over arrays. It gives the exact solver's ``colliding``,
``axis``, ``normal``, type and features bit for bit (tested), and its ``depth`` except on face
contacts whose incident box hangs beyond the reference face: there the labeller keeps the SAT
overlap and the exact solver reports the shallower deepest point of the footprint
(:mod:`impactnet.models.box.kernels`, stage 4).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.exact import checked_rows, fault_error
from impactnet.models.box.kernel_face import from_reference
from impactnet.models.box.kernel_frame import maximum, minimum, moved
from impactnet.models.box.kernel_inputs import first_fault
from impactnet.models.box.kernel_views import decision_rows, pair_frame
from impactnet.models.box.tolerances import SNAP_TOL_REL
from impactnet.models.compiled import jit, numba, parallel_jit
from impactnet.models.learned.kernel_mlp import TILE_ROWS, run_rows

#: Relative floor (x pair scale, metres) added to each vertex weight of the unclipped point, so
#: that touching vertices at zero depth average evenly instead of dividing 0 by 0.
WEIGHT_FLOOR_REL = 1e-12
#: Largest depth spread over the incident face (x pair scale, metres) for which it counts as
#: parallel to the reference face: then its side faces are edge-on, the pressure is uniform and
#: the centre of pressure of an aligned overlap is the mean of the clamped corners.
PARALLEL_DEPTH_REL = 1e-12
#: Largest sine (dimensionless) between an incident face's edge and the reference face's axes
#: for which the two rectangles count as aligned: then clamping the incident corners into the
#: reference rectangle gives the corners of their intersection (off by sine x size at most).
ALIGNED_SINE_MAX = 1e-9
#: Smallest |det| (x the quad's area scale squared, dimensionless) of the incident face's
#: (u, w) projection for which its depth plane is solved; below it the face stands edge-on
#: to the reference face and each vertex keeps its own depth.
PLANE_DET_MIN_REL = 1e-9


class Labels(NamedTuple):
    """The exact decision for m pairs (world frame where a frame applies)."""

    colliding: np.ndarray  # (m,) bool
    axis: np.ndarray  # (m,) int8, separating-axis id 0-14
    depth: np.ndarray  # (m,) float64, metres (0 where separated)
    normal: np.ndarray  # (m, 3) float64, unit, from A towards B, world frame
    code: np.ndarray  # (m,) int8, contact type code (impactnet.models.contacts)
    feature_a: np.ndarray  # (m,) int8, feature id in A (box_features), -1 for none
    feature_b: np.ndarray  # (m,) int8, feature id in B, -1 for none
    exact_point: np.ndarray  # (m,) bool: ``unclipped`` is the exact point (edge-edge, and
    # parallel aligned face contacts with every incident vertex touching)
    unclipped: np.ndarray  # (m, 3) float64, world frame, metres: the point before clipping
    # (face_point; an edge-edge contact's exact point; A's centre where separated)


@jit
def _plane_depths(quad, depth, u, w):
    """Depths (4-tuple) of the incident face's plane at the points (u[k], w[k]), from the quad's
    vertices (``quad`` (4, 3): along, u, w; ``depth``: theirs); the vertices' own depths where
    the face stands edge-on (:data:`PLANE_DET_MIN_REL`)."""
    du1, dw1, dd1 = quad[1, 1] - quad[0, 1], quad[1, 2] - quad[0, 2], depth[1] - depth[0]
    du3, dw3, dd3 = quad[3, 1] - quad[0, 1], quad[3, 2] - quad[0, 2], depth[3] - depth[0]
    det = du1 * dw3 - du3 * dw1
    size2 = (du1 * du1 + dw1 * dw1) * (du3 * du3 + dw3 * dw3)
    if not abs(det) > PLANE_DET_MIN_REL * math.sqrt(size2):
        return depth
    grad_u = (dd1 * dw3 - dd3 * dw1) / det
    grad_w = (du1 * dd3 - du3 * dd1) / det
    return (depth[0] + grad_u * (u[0] - quad[0, 1]) + grad_w * (w[0] - quad[0, 2]),
            depth[0] + grad_u * (u[1] - quad[0, 1]) + grad_w * (w[1] - quad[0, 2]),
            depth[0] + grad_u * (u[2] - quad[0, 1]) + grad_w * (w[2] - quad[0, 2]),
            depth[0] + grad_u * (u[3] - quad[0, 1]) + grad_w * (w[3] - quad[0, 2]))


@jit
def _aligned(quad):
    """Whether the incident quad projects onto a rectangle aligned with the reference face's
    axes (its two edges from vertex 0 along u or w within :data:`ALIGNED_SINE_MAX`)."""
    for j in (1, 3):
        du, dw = abs(quad[j, 1] - quad[0, 1]), abs(quad[j, 2] - quad[0, 2])
        if min(du, dw) > ALIGNED_SINE_MAX * max(du, dw):
            return False
    return True


@jit
def _clamp(x, half):
    """``x`` clamped into [-half, half] (NumPy's ``clip``)."""
    return minimum(maximum(x, -half), half)


@jit
def face_point(quad, reference, scale):
    """The unclipped point of a face contact and whether it is the exact point.

    Parameters
    ----------
    quad : ndarray, shape (4, 3)
        The incident face's vertices (reference coordinates along the axis, u, w; metres).
    reference : ndarray, shape (4,)
        The reference face's half-extents (along the axis, u, w; metres) and side (+-1).
    scale : float
        Pair scale (metres).

    Returns
    -------
    point : 3-tuple
        The point the touching incident vertices (depth >= -tolerance) give when each is
        clamped into the reference face's rectangle instead of clipped (reference coordinates
        along the axis, u, w; metres): their depth-weighted mean (depths of the incident face's
        plane at the clamped points), on the mid-surface. It is the exact point (the centre of
        pressure) where the incident face is parallel to and aligned with the reference face
        and every vertex touches (clamping a rectangle's corners into an aligned rectangle
        gives their intersection's corners, under a uniform pressure); elsewhere it is a
        baseline, and the committee's experts learn the rest.
    exact : bool
        The point is the exact point (aligned, parallel within :data:`PARALLEL_DEPTH_REL`,
        every vertex touching).
    """
    height, half_u, half_w, ref_sign = reference[0], reference[1], reference[2], reference[3]
    tol = SNAP_TOL_REL * scale
    depth = (height - ref_sign * quad[0, 0], height - ref_sign * quad[1, 0],
             height - ref_sign * quad[2, 0], height - ref_sign * quad[3, 0])
    u = (_clamp(quad[0, 1], half_u), _clamp(quad[1, 1], half_u), _clamp(quad[2, 1], half_u),
         _clamp(quad[3, 1], half_u))
    w = (_clamp(quad[0, 2], half_w), _clamp(quad[1, 2], half_w), _clamp(quad[2, 2], half_w),
         _clamp(quad[3, 2], half_w))
    clamped = _plane_depths(quad, depth, u, w)
    total = pressed = along_u = along_w = 0.0
    touching, low, high = True, depth[0], depth[0]
    for k in range(4):
        weight = 0.0
        if depth[k] >= -tol:
            weight = maximum(clamped[k], 0.0) + WEIGHT_FLOOR_REL * scale
        else:
            touching = False
        total += weight
        pressed += weight * clamped[k]
        along_u += weight * u[k]
        along_w += weight * w[k]
        low, high = min(low, depth[k]), max(high, depth[k])
    point = (ref_sign * height - ref_sign * 0.5 * pressed / total, along_u / total,
             along_w / total)
    return point, touching and _aligned(quad) and high - low <= PARALLEL_DEPTH_REL * scale


#: Scratch of :func:`label`: float64 slots and int8 slots (:func:`scratch`).
LABEL_FLOATS, LABEL_SMALL = 24, 5


@jit
def scratch(floats, small):
    """The one-row outputs of :func:`~impactnet.models.box.kernel_views.decision_rows` as views
    of the caller's ``floats`` (>= LABEL_FLOATS,) float64 and ``small`` (>= LABEL_SMALL,) int8
    (no allocation here): colliding, axis, depth, normal, code, feature_a, feature_b, point,
    quad, reference, scale."""
    return (small[4:5].view(np.bool_), small[0:1], floats[0:1], floats[1:4].reshape((1, 3)),
            small[1:2], small[2:3], small[3:4], floats[4:7].reshape((1, 3)),
            floats[7:19].reshape((1, 4, 3)), floats[19:23].reshape((1, 4)), floats[23:24])


@jit
def _one_row(rows, i):
    """Row i of an input (k, w) as a (1, w) view (a one-row input as it is)."""
    return rows if rows.shape[0] == 1 else rows[i:i + 1]


@jit
def label(inputs, i, work):
    """The exact labels of pair i of ``inputs`` (the six checked (k, w) float64 rows, k 1 or
    n; quaternions not necessarily unit), with ``work`` from :func:`scratch`.

    Returns ``(colliding, axis, depth, normal, code, feature_a, feature_b, exact_point,
    unclipped)`` as :class:`Labels` holds them, the vectors as 3-tuples (world frame).
    """
    one = (_one_row(inputs[0], i), _one_row(inputs[1], i), _one_row(inputs[2], i),
           _one_row(inputs[3], i), _one_row(inputs[4], i), _one_row(inputs[5], i))
    colliding, axis, depth, normal, code, feature_a, feature_b, point, quad, reference, \
        scale = work
    decision_rows(one, colliding, axis, depth, normal, code, feature_a, feature_b, point, quad,
                  reference, scale)
    hit, chosen = colliding[0], axis[0]
    unclipped = (point[0, 0], point[0, 1], point[0, 2])  # edge-edge point, else A's centre
    exact = hit and code[0] == ct.EDGE_EDGE
    if hit and chosen < 6:
        local, exact = face_point(quad[0], reference[0], scale[0])
        pa, rot_a, frame = pair_frame(inputs, i)
        p = from_reference(chosen % 3, local[0], local[1], local[2])
        if chosen >= 3:  # the reference face is B's: to A's frame
            p = moved(frame[3], frame[2], p)
        unclipped = moved(pa, rot_a, p)
    return (hit, chosen, depth[0], (normal[0, 0], normal[0, 1], normal[0, 2]), code[0],
            feature_a[0], feature_b[0], exact, unclipped)


@jit
def _label_into(inputs, i, work, out):
    """Row i's labels into the arrays ``out`` (:class:`Labels`' fields, n rows)."""
    hit, axis, depth, normal, code, feature_a, feature_b, exact, unclipped = label(inputs, i,
                                                                                   work)
    out[0][i], out[1][i], out[2][i], out[4][i] = hit, axis, depth, code
    out[5][i], out[6][i], out[7][i] = feature_a, feature_b, exact
    for c in range(3):
        out[3][i, c], out[8][i, c] = normal[c], unclipped[c]


@jit
def label_rows(inputs, out, start, stop):
    """The labels of pairs ``start:stop`` into ``out`` (:class:`Labels`' arrays), serially."""
    work = scratch(np.empty(LABEL_FLOATS), np.empty(LABEL_SMALL, np.int8))
    for i in range(start, stop):
        _label_into(inputs, i, work, out)


@parallel_jit
def label_rows_parallel(inputs, out, start, stop):
    """:func:`label_rows` over the kernel threads, a tile of rows at a time."""
    tiles = (stop - start + TILE_ROWS - 1) // TILE_ROWS
    for tile in numba.prange(tiles):
        work = scratch(np.empty(LABEL_FLOATS), np.empty(LABEL_SMALL, np.int8))
        for i in range(start + tile * TILE_ROWS, min(stop, start + (tile + 1) * TILE_ROWS)):
            _label_into(inputs, i, work, out)


def label_block(inputs) -> Labels:
    """Exact labels of the n pairs of ``inputs`` (the six inputs as ``box_box`` takes them,
    checked as it checks them: same errors)."""
    rows, n = checked_rows(*inputs)
    fault = first_fault(*rows, n)
    if fault:
        raise fault_error(fault, rows, n)
    out = Labels(np.empty(n, np.bool_), np.empty(n, np.int8), np.empty(n), np.empty((n, 3)),
                 np.empty(n, np.int8), np.empty(n, np.int8), np.empty(n, np.int8),
                 np.empty(n, np.bool_), np.empty((n, 3)))
    run_rows(label_rows, label_rows_parallel, n, tuple(rows), tuple(out))
    return out


def unclipped_points(size_a, position_a, quaternion_a, size_b, position_b,
                     quaternion_b) -> tuple[np.ndarray, np.ndarray]:
    """The unclipped points (n, 3) (world frame, metres) and their ``exact_point`` flags (n,)
    (see :class:`Labels`) of n pairs, arguments as :func:`impactnet.models.box.exact.box_box`
    (the experts' training targets are the exact point minus this, on the rows not flagged)."""
    labels = label_block((size_a, position_a, quaternion_a, size_b, position_b, quaternion_b))
    return labels.unclipped, labels.exact_point
