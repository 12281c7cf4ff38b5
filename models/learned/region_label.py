"""The committee's region classifier: the exact solver's own decision, without the clipping.

The region of a contact (contact type, feature of A, feature of B) is decided at tolerance
scale: on about a quarter of first-contact poses the separating-axis margin is below 1e-4 of
the pair's size, and the tie rules (1e-12 of the size) pick the axis and the incident feature
(docs/classifier_study.md). A classifier that is to agree with the exact solver there must
repeat its float64 arithmetic, so it does, and costs less than a learned one would:

1. the separating-axis test and its tie rule (:func:`impactnet.models.box.exact.contact_axes`) give
"none",
   the axis, the depth and the normal, exactly;
2. for a face axis, the incident face's four vertex depths name the incident feature
   (:func:`impactnet.models.box.manifold.incident_feature`); for a cross axis, the two supporting
   edges
   (:func:`impactnet.models.box.manifold.edge_contact`).

What is left for the learned experts is the point, whose exact computation (the centre of
pressure of the clipped footprint, :mod:`impactnet.models.box.pressure`) is the expensive part.
:func:`label_block` is the batch path (columns, as :mod:`impactnet.models.box.exact`),
:func:`label_one` the
N = 1 path in Python floats (as :mod:`impactnet.models.box.exact_one`); both give the exact solver's
``colliding``, ``axis``, ``normal``, type and features bit for bit (tested), and its ``depth``
except on face contacts whose incident box hangs beyond the reference face: there the labeller
keeps the SAT overlap and the exact solver reports the shallower deepest point of the footprint
(:mod:`impactnet.models.box.exact`, stage 4).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box import exact_one as es
from impactnet.models.box import local_frame as lf
from impactnet.models.box import manifold as mf
from impactnet.models.box.exact import CHUNK_ROWS, contact_axes, prepare_inputs, unit_quaternions
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
    # (impactnet.models.box.manifold.face_features; an edge-edge contact's exact point; A's centre
    # where
    # separated)


def input_block(inputs, start: int, stop: int) -> np.ndarray:
    """Rows ``start:stop`` of validated inputs as a (20, m) column block for
    :func:`label_block`, quaternions normalised as :func:`impactnet.models.box.exact.prepare_inputs`
    does
    (so that the labels are the exact solver's bit for bit).

    ``inputs``: a :class:`impactnet.models.learned.pose_columns.Inputs`; its 1-row arrays are
    broadcast.
    """
    m = stop - start
    block = np.empty((lf.INPUT_ROWS, m))
    for rows, value in zip(lf.INPUT_SLICES, inputs[:6]):
        part = value if len(value) == 1 else value[start:stop]
        if part.shape[1] == 4:
            part = unit_quaternions(part)
        block[rows] = part.T
    return block


def label_block(block: np.ndarray) -> Labels:
    """Exact labels of the m pairs of an input block.

    Parameters
    ----------
    block : ndarray, shape (20, m)
        Input columns of :func:`impactnet.models.box.local_frame.input_columns` (float64).
    """
    pose, rot_a = lf.local_pose(block)
    m = block.shape[1]
    colliding, axis, depth, normal, (edge_rows, edge_point, edge_a, edge_b) = contact_axes(pose)
    code = np.zeros(m, np.int8)
    feature_a = np.full(m, bf.NO_FEATURE, np.int8)
    feature_b = np.full(m, bf.NO_FEATURE, np.int8)
    unclipped = np.zeros((3, m))  # A's frame
    exact_point = np.zeros(m, bool)
    face = colliding & (axis < 6)
    rows = np.flatnonzero(face)
    if rows.size:
        ref_is_b = axis[rows] >= 3
        frame = mf.ReferenceFrame(pose, rows, ref_is_b, axis[rows] % 3)
        incident, rank, ref_face, point, exact_point[rows] = face_features(frame,
                                                                          pose.scale[rows])
        code[rows], feature_a[rows], feature_b[rows] = mf.face_labels(ref_is_b, incident, rank,
                                                                      ref_face)
        flip = np.flatnonzero(ref_is_b)  # points in B's frame: map them to A's
        if flip.size:
            point[:, flip] = lf.b_to_a(pose, rows[flip], point[:, flip])
        unclipped[:, rows] = point
    if edge_rows.size:
        unclipped[:, edge_rows] = edge_point
        feature_a[edge_rows], feature_b[edge_rows] = edge_a, edge_b
        exact_point[edge_rows] = True
        code[edge_rows] = ct.EDGE_EDGE
    world = block[lf.INPUT_SLICES[1]] + lf.matvec(rot_a, unclipped)
    return Labels(colliding, axis.astype(np.int8), depth, lf.matvec(rot_a, normal), code,
                  feature_a, feature_b, exact_point, world)


def face_features(frame: mf.ReferenceFrame, scale):
    """The labels of :func:`impactnet.models.box.manifold.face_manifold` without the clipping, and
    an
    approximate point.

    Returns
    -------
    incident_feature, touching_rank, ref_face : ndarray of int, shape (m,)
        As :func:`impactnet.models.box.manifold.face_manifold`'s.
    unclipped : ndarray, shape (3, m)
        The point the touching incident vertices (depth >= -tolerance) give when each is
        clamped into the reference face's rectangle instead of clipped (reference frame,
        metres): their depth-weighted mean (depths of the incident face's plane at the
        clamped points), on the mid-surface. It is the exact point (the centre of pressure)
        where the incident face is parallel to and aligned with the reference face and every
        vertex touches (clamping a rectangle's corners into an aligned rectangle gives their
        intersection's corners, under a uniform pressure); elsewhere it is a baseline, and
        the committee's experts learn the rest.
    exact : ndarray of bool, shape (m,)
        The unclipped point is the exact point (aligned, parallel within
        :data:`PARALLEL_DEPTH_REL`, every vertex touching).
    """
    tol = mf.SNAP_TOL_REL * scale
    vertices, ref_sign, k, side = mf.incident_quad(frame)
    height, half_u, half_w = frame.half_ref()
    depth = height - ref_sign * vertices[:, 0]
    feature, rank = mf.incident_feature(depth, k, side, tol)
    u = np.clip(vertices[:, 1], -half_u, half_u)
    w = np.clip(vertices[:, 2], -half_w, half_w)
    clamped = plane_depth(vertices[:, 1], vertices[:, 2], depth, u, w)
    weight = np.where(depth >= -tol, np.maximum(clamped, 0.0) + WEIGHT_FLOOR_REL * scale, 0.0)
    total = weight.sum(axis=0)
    along = ref_sign * height - ref_sign * 0.5 * (weight * clamped).sum(axis=0) / total
    unclipped = mf.from_reference(frame.ref_axis, along, (weight * u).sum(axis=0) / total,
                               (weight * w).sum(axis=0) / total)
    quad_u, quad_w = vertices[:, 1], vertices[:, 2]
    spread = depth.max(axis=0) - depth.min(axis=0)
    exact = (aligned(quad_u, quad_w) & (depth >= -tol).all(axis=0)
             & (spread <= PARALLEL_DEPTH_REL * scale))
    return feature, rank, bf.face_id(frame.ref_axis, ref_sign < 0), unclipped, exact


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
    (see :class:`Labels`) of n pairs, arguments as :func:`impactnet.models.box.exact.box_box` (the
    experts'
    training targets are the exact point minus this, on the rows not flagged)."""
    inputs = prepare_inputs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    n = len(inputs[0])
    out, exact = np.empty((n, 3)), np.empty(n, bool)
    for start in range(0, n, CHUNK_ROWS):
        stop = min(n, start + CHUNK_ROWS)
        labels = label_block(lf.input_columns(inputs, start, stop))
        out[start:stop], exact[start:stop] = labels.unclipped.T, labels.exact_point
    return out, exact


def label_one(values) -> tuple:
    """Exact labels of one validated pair (the lists of :func:`impactnet.models.box.exact_one.
    single_pair`): ``(colliding, axis, depth, normal, code, feature_a, feature_b,
    exact_point, unclipped, decision)``, the normal and the unclipped point (see
    :class:`Labels`) as 3 floats in the world frame, and the separating-axis
    :class:`~impactnet.models.box.exact_one.Decision` behind them (the exact fallback finishes
    from it)."""
    decision = es.decide_one(*values)
    ha, hb, rot, t, rot_a, scale = decision.frame
    _, colliding, axis, normal, depth, edge = decision
    world = es.apply(rot_a, normal)
    if not colliding:
        return (False, axis, 0.0, world, ct.NONE, bf.NO_FEATURE, bf.NO_FEATURE, False,
                list(values[1]), decision)
    if axis < 6:
        code, feature_a, feature_b, point, exact = _face_labels_one(ha, hb, rot, t, axis, scale)
    else:
        point, feature_a, feature_b = edge
        code, exact = ct.EDGE_EDGE, True
    pa = values[1]
    unclipped = [pa[r] + es.dot(rot_a[r], point) for r in range(3)]
    return True, axis, depth, world, code, feature_a, feature_b, exact, unclipped, decision


def _face_labels_one(ha, hb, rot, t, axis, scale):
    """(type code, feature of A, feature of B, unclipped point in A's frame, exact flag) of
    one face-axis contact (as :func:`face_features`)."""
    h_ref, h_inc, rot_ri, t_ri = es.reference_view(ha, hb, rot, t, axis)
    ref_axis = axis % 3
    ref_sign, vertices, signs, depth, face = es.incident_face(h_ref, h_inc, rot_ri, t_ri,
                                                             ref_axis)
    tol = mf.SNAP_TOL_REL * scale
    incident, rank = es.incident_feature(depth, signs, face, tol)
    ref_face = bf.FACE_BASE + 2 * ref_axis + (ref_sign < 0)
    u_axis, w_axis = (ref_axis + 1) % 3, (ref_axis + 2) % 3
    quad = [(v[u_axis], v[w_axis]) for v in vertices]
    clamped = [(min(max(u, -h_ref[u_axis]), h_ref[u_axis]),
                min(max(w, -h_ref[w_axis]), h_ref[w_axis])) for u, w in quad]
    depths = _plane_depth_one(quad, depth, clamped)
    weights = [max(dc, 0.0) + WEIGHT_FLOOR_REL * scale if d >= -tol else 0.0
               for d, dc in zip(depth, depths)]
    total = sum(weights)
    point = [0.0, 0.0, 0.0]
    point[ref_axis] = (ref_sign * h_ref[ref_axis]
                       - ref_sign * 0.5 * sum(w * d for w, d in zip(weights, depths)) / total)
    point[u_axis] = sum(w * c[0] for w, c in zip(weights, clamped)) / total
    point[w_axis] = sum(w * c[1] for w, c in zip(weights, clamped)) / total
    exact = (all(d >= -tol for d in depth) and _aligned_one(quad)
             and max(depth) - min(depth) <= PARALLEL_DEPTH_REL * scale)
    if axis >= 3:
        point = [t[r] + es.dot(rot[r], point) for r in range(3)]
        return es.FACE_INC_CODES[rank], incident, ref_face, point, exact
    return es.FACE_REF_CODES[rank], ref_face, incident, point, exact


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
