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

(both the solver's own kernels: :func:`impactnet.models.box.decision.decisions`).

What is left for the learned experts is the point, whose exact computation (the centre of
pressure of the clipped footprint, :mod:`impactnet.models.box.kernel_pressure`) is the expensive
part. :func:`label_block` is the batch path, :func:`label_one` the N = 1 path in Python floats;
both give the exact solver's
``colliding``, ``axis``, ``normal``, type and features bit for bit (tested), and its ``depth``
except on face contacts whose incident box hangs beyond the reference face: there the labeller
keeps the SAT overlap and the exact solver reports the shallower deepest point of the footprint
(:mod:`impactnet.models.box.kernels`, stage 4).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.decision import decide_one, decisions, reference_to_world
from impactnet.models.box.exact import checked_rows
from impactnet.models.box.tolerances import SNAP_TOL_REL
from impactnet.models.compiled import CHUNK_ROWS
from impactnet.models.geometry import box_features as bf
from impactnet.models.learned.pair_dispatch import MIRROR_AXIS, MIRROR_TYPE


class Labels(NamedTuple):
    """The exact decision for m pairs (world frame where a frame applies)."""

    colliding: np.ndarray  # (m,) bool
    axis: np.ndarray  # (m,) int8, separating-axis id 0-14
    depth: np.ndarray  # (m,) float64, metres (0 where separated)
    normal: np.ndarray  # (3, m) float64, unit, from A towards B, world frame
    code: np.ndarray  # (m,) int8, contact type code (impactnet.models.contacts)
    # (m,) int8, feature id in A (impactnet.models.geometry.box_features), -1 for none
    feature_a: np.ndarray
    feature_b: np.ndarray  # (m,) int8, feature id in B, -1 for none
    exact_point: np.ndarray  # (m,) bool: ``unclipped`` is the exact point (edge-edge, and
    # parallel aligned face contacts with every incident vertex touching)
    unclipped: np.ndarray  # (3, m) float64, world frame, metres: the point before clipping
    # (face_features; an edge-edge contact's exact point; A's centre where separated)


def input_block(inputs, start: int, stop: int) -> tuple:
    """Rows ``start:stop`` of validated inputs as the six arrays of :func:`label_block` (one-row
    arrays kept, to broadcast; A's sizes repeated where every input has one row).

    ``inputs``: a :class:`impactnet.models.learned.pose_columns.Inputs` (or the six arrays).
    """
    block = [value if len(value) == 1 else value[start:stop] for value in inputs[:6]]
    if all(len(value) == 1 for value in block):
        block[0] = np.repeat(block[0], stop - start, axis=0)
    return tuple(block)


def label_block(block) -> Labels:
    """Exact labels of the m pairs of an input block (:func:`input_block`: the six inputs as
    ``box_box`` takes them, quaternions not necessarily unit)."""
    found = decisions(*block)
    unclipped = found.point.copy()  # edge-edge points, A's centre elsewhere (world)
    exact_point = found.code == ct.EDGE_EDGE
    rows = np.flatnonzero(found.colliding & (found.axis < 6))
    if rows.size:
        local, exact_point[rows] = face_features(found.quad[rows], found.reference[rows],
                                                 found.scale[rows])
        unclipped[rows] = reference_to_world(block, rows, found.axis[rows], local.T)
    return Labels(found.colliding, found.axis, found.depth, found.normal.T, found.code,
                  found.feature_a, found.feature_b, exact_point, unclipped.T)


def face_features(quad, reference, scale):
    """An approximate point of m face contacts, without the clipping.

    Parameters
    ----------
    quad : ndarray, shape (m, 4, 3)
        The incident face's vertices (reference coordinates along the axis, u, w; metres).
    reference : ndarray, shape (m, 4)
        The reference face's half-extents (along the axis, u, w; metres) and side (+-1).
    scale : ndarray, shape (m,)
        Pair scale (metres).

    Returns
    -------
    unclipped : ndarray, shape (3, m)
        The point the touching incident vertices (depth >= -tolerance) give when each is
        clamped into the reference face's rectangle instead of clipped (reference coordinates
        along the axis, u, w; metres): their depth-weighted mean (depths of the incident face's
        plane at the clamped points), on the mid-surface. It is the exact point (the centre of
        pressure) where the incident face is parallel to and aligned with the reference face
        and every vertex touches (clamping a rectangle's corners into an aligned rectangle
        gives their intersection's corners, under a uniform pressure); elsewhere it is a
        baseline, and the committee's experts learn the rest.
    exact : ndarray of bool, shape (m,)
        The unclipped point is the exact point (aligned, parallel within
        :data:`PARALLEL_DEPTH_REL`, every vertex touching).
    """
    tol = SNAP_TOL_REL * scale
    vertices = quad.transpose(1, 2, 0)  # (4, 3, m)
    height, half_u, half_w, ref_sign = reference.T
    depth = height - ref_sign * vertices[:, 0]
    u = np.clip(vertices[:, 1], -half_u, half_u)
    w = np.clip(vertices[:, 2], -half_w, half_w)
    clamped = plane_depth(vertices[:, 1], vertices[:, 2], depth, u, w)
    weight = np.where(depth >= -tol, np.maximum(clamped, 0.0) + WEIGHT_FLOOR_REL * scale, 0.0)
    total = weight.sum(axis=0)
    along = ref_sign * height - ref_sign * 0.5 * (weight * clamped).sum(axis=0) / total
    unclipped = np.array([along, (weight * u).sum(axis=0) / total,
                          (weight * w).sum(axis=0) / total])
    quad_u, quad_w = vertices[:, 1], vertices[:, 2]
    spread = depth.max(axis=0) - depth.min(axis=0)
    exact = (aligned(quad_u, quad_w) & (depth >= -tol).all(axis=0)
             & (spread <= PARALLEL_DEPTH_REL * scale))
    return unclipped, exact


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


def aligned(quad_u, quad_w) -> np.ndarray:
    """Whether the incident quad (4, m) projects onto a rectangle aligned with the reference
    face's axes, (m,) bool. With every vertex touching, the clamped point is then exact."""
    ok = np.ones(quad_u.shape[1], bool)
    for j in (1, 3):  # the quad's two edge directions, from vertex 0
        du, dw = np.abs(quad_u[j] - quad_u[0]), np.abs(quad_w[j] - quad_w[0])
        ok &= np.minimum(du, dw) <= ALIGNED_SINE_MAX * np.maximum(du, dw)
    return ok


#: Smallest |det| (x the quad's area scale squared, dimensionless) of the incident face's
#: (u, w) projection for which its depth plane is solved; below it the face stands edge-on
#: to the reference face and each vertex keeps its own depth.
PLANE_DET_MIN_REL = 1e-9


def plane_depth(quad_u, quad_w, depth, u, w) -> np.ndarray:
    """Depths (4, m) of the incident face's plane at points (u, w) (4, m), from the quad's
    vertices (``quad_u``, ``quad_w``, ``depth``, each (4, m)); the vertices' own depths where
    the face is edge-on (:data:`PLANE_DET_MIN_REL`)."""
    du1, dw1, dd1 = quad_u[1] - quad_u[0], quad_w[1] - quad_w[0], depth[1] - depth[0]
    du3, dw3, dd3 = quad_u[3] - quad_u[0], quad_w[3] - quad_w[0], depth[3] - depth[0]
    det = du1 * dw3 - du3 * dw1
    size2 = (du1 * du1 + dw1 * dw1) * (du3 * du3 + dw3 * dw3)
    solvable = np.abs(det) > PLANE_DET_MIN_REL * np.sqrt(size2)
    safe = np.where(solvable, det, 1.0)
    grad_u = (dd1 * dw3 - dd3 * dw1) / safe
    grad_w = (du1 * dd3 - du3 * dd1) / safe
    planar = depth[0] + grad_u * (u - quad_u[0]) + grad_w * (w - quad_w[0])
    return np.where(solvable, planar, depth)


def mirrored(labels: Labels) -> Labels:
    """The labels of the same m contacts with A and B exchanged (normal negated, features
    exchanged, types and axes mirrored): how the committee labels a pair in the request's order
    and then solves it in the bundle's order, so that at exact ties it names the contact as
    the exact solver does for the request."""
    return labels._replace(axis=MIRROR_AXIS[labels.axis], normal=-labels.normal,
                           code=MIRROR_TYPE[labels.code], feature_a=labels.feature_b,
                           feature_b=labels.feature_a)


def unclipped_points(size_a, position_a, quaternion_a, size_b, position_b,
                     quaternion_b) -> np.ndarray:
    """The unclipped points (n, 3) (world frame, metres) and their ``exact_point`` flags (n,)
    (see :class:`Labels`) of n pairs, arguments as :func:`impactnet.models.box.exact.box_box`
    (the experts' training targets are the exact point minus this, on the rows not flagged)."""
    rows, n = checked_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    out, exact = np.empty((n, 3)), np.empty(n, bool)
    for start in range(0, n, CHUNK_ROWS):
        stop = min(n, start + CHUNK_ROWS)
        labels = label_block(input_block(rows, start, stop))
        out[start:stop], exact[start:stop] = labels.unclipped.T, labels.exact_point
    return out, exact


def label_one(values) -> tuple:
    """Exact labels of one validated pair (:func:`impactnet.models.box.decision.single_pair`):
    ``(colliding, axis, depth, normal, code, feature_a, feature_b, exact_point, unclipped,
    decision)``, the normal and the unclipped point (see :class:`Labels`) as 3 floats in the
    world frame, and the solver's :class:`~impactnet.models.box.decision.Decision` behind them
    (the exact fallback finishes from it)."""
    decision = decide_one(values)
    axis, normal, code = decision.axis, decision.normal, decision.code
    if not decision.colliding:
        return (False, axis, 0.0, normal, ct.NONE, bf.NO_FEATURE, bf.NO_FEATURE, False,
                list(values[1]), decision)
    exact, unclipped = True, decision.point  # edge-edge: the exact point
    if axis < 6:
        local, exact = _face_point_one(decision.quad, decision.reference, decision.scale)
        unclipped = reference_to_world(values.rows, [0], [axis], [local])[0].tolist()
    return (True, axis, decision.depth, normal, code, decision.feature_a, decision.feature_b,
            exact, unclipped, decision)


def _face_point_one(quad, reference, scale):
    """The unclipped point of one face contact (reference coordinates along the axis, u, w)
    and its exact flag, as :func:`face_features`."""
    height, half_u, half_w, ref_sign = reference
    tol = SNAP_TOL_REL * scale
    depth = [height - ref_sign * v[0] for v in quad]
    quad = [(v[1], v[2]) for v in quad]
    clamped = [(min(max(u, -half_u), half_u), min(max(w, -half_w), half_w)) for u, w in quad]
    depths = _plane_depth_one(quad, depth, clamped)
    weights = [max(dc, 0.0) + WEIGHT_FLOOR_REL * scale if d >= -tol else 0.0
               for d, dc in zip(depth, depths)]
    total = sum(weights)
    point = [ref_sign * height - ref_sign * 0.5 * sum(w * d for w, d in zip(weights, depths))
             / total, sum(w * c[0] for w, c in zip(weights, clamped)) / total,
             sum(w * c[1] for w, c in zip(weights, clamped)) / total]
    exact = (all(d >= -tol for d in depth) and _aligned_one(quad)
             and max(depth) - min(depth) <= PARALLEL_DEPTH_REL * scale)
    return point, exact


def _aligned_one(quad) -> bool:
    """:func:`aligned` of one contact (``quad``: 4 (u, w) pairs)."""
    for j in (1, 3):
        du, dw = abs(quad[j][0] - quad[0][0]), abs(quad[j][1] - quad[0][1])
        if min(du, dw) > ALIGNED_SINE_MAX * max(du, dw):
            return False
    return True


def _plane_depth_one(quad, depth, points):
    """Depths of the incident face's plane at 4 points (u, w), as
    :func:`plane_depth`."""
    (u0, w0), (u1, w1), _, (u3, w3) = quad
    du1, dw1, dd1 = u1 - u0, w1 - w0, depth[1] - depth[0]
    du3, dw3, dd3 = u3 - u0, w3 - w0, depth[3] - depth[0]
    det = du1 * dw3 - du3 * dw1
    size2 = (du1 * du1 + dw1 * dw1) * (du3 * du3 + dw3 * dw3)
    if not abs(det) > PLANE_DET_MIN_REL * size2 ** 0.5:
        return list(depth)
    grad_u = (dd1 * dw3 - dd3 * dw1) / det
    grad_w = (du1 * dd3 - du3 * dd1) / det
    return [depth[0] + grad_u * (u - u0) + grad_w * (w - w0) for u, w in points]
