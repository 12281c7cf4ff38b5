"""Contact manifolds for N box pairs: face clipping and edge-edge closest points.

Stage 2 of the exact solver (see :mod:`models.exact`).

Face axes. The box that owns the chosen face axis is the *reference* box; the other one is the
*incident* box. Everything happens in the reference box's frame, where the reference face is
the axis-aligned rectangle ``|u| <= h_u, |w| <= h_w`` in the plane ``x_axis = sign * h_axis``.
The incident face is the incident box's face most anti-parallel to the normal. Its clip
against the rectangle (the Sutherland-Hodgman result) is found in closed form: the vertices
of the intersection of a convex quad and a rectangle are (a) quad vertices inside the
rectangle, (b) rectangle corners inside the quad, (c) crossings of a quad edge with the
interior of a rectangle edge. Coincidences within :data:`SNAP_TOL_REL` are counted once,
in that order of priority, so a stack of equal boxes gives 4 points, not 8. Points above the
reference plane (negative depth) are dropped. The reported points lie on the mid-surface
(moved by half their depth towards the incident box).

The incident feature is named by how many of the incident face's vertices penetrate: one
vertex, two (an edge) or three or more (the face).

Edge axes. The supporting edge of A along +normal and of B along -normal; the contact point is
the midpoint of their closest points (clamped to the edges).
"""
from __future__ import annotations

import numpy as np

from models import box_features as bf
from models.contacts import MAX_MANIFOLD_POINTS
from models.sat import sign_nonnegative

#: Relative tolerance (x pair scale, metres) under which two candidate manifold points, or a
#: point and a clip boundary, are the same: equal boxes stacked exactly produce coincident
#: candidates that differ only by rounding.
SNAP_TOL_REL = 1e-12
#: Relative floor (x pair scale, metres) added to each manifold weight, so that a manifold at
#: zero depth averages its points evenly instead of dividing 0 by 0.
WEIGHT_FLOOR_REL = 1e-12
#: Quad vertices in cyclic order, as signs along the incident face's two in-plane axes.
QUAD_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
#: Rectangle corners as signs along (u, w).
RECT_SIGNS = QUAD_SIGNS


def _gather(array: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``array[..., index[...]]`` along the last axis; ``index`` has shape ``array.shape[:-1]``."""
    return np.take_along_axis(array, index[..., None], axis=-1)[..., 0]


def _column(matrix: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Column ``index[n]`` of each (3, 3) matrix, shape (n, 3)."""
    return np.take_along_axis(matrix, index[:, None, None], axis=2)[:, :, 0]


def incident_face(half_inc, rot_ri, t_ri, ref_axis, ref_sign):
    """The incident face's vertices and their signs in the incident box's frame.

    Returns
    -------
    vertices : ndarray, shape (n, 4, 3)
        Quad vertices in the reference frame, cyclic order.
    vertex_signs : ndarray, shape (n, 4, 3)
        Signs (+-1) of each vertex in the incident box's frame.
    face : ndarray, shape (n,)
        Incident face id in the incident box.
    """
    n = t_ri.shape[0]
    normal_in_inc = ref_sign[:, None] * np.take_along_axis(rot_ri, ref_axis[:, None, None], 1)[:, 0]
    k = np.argmax(np.abs(normal_in_inc), axis=1)
    side = -sign_nonnegative(_gather(normal_in_inc, k))
    p, q = (k + 1) % 3, (k + 2) % 3
    centre = t_ri + (side * _gather(half_inc, k))[:, None] * _column(rot_ri, k)
    edge_p = _gather(half_inc, p)[:, None] * _column(rot_ri, p)
    edge_q = _gather(half_inc, q)[:, None] * _column(rot_ri, q)
    a, b = QUAD_SIGNS[:, 0], QUAD_SIGNS[:, 1]
    vertices = centre[:, None] + a[None, :, None] * edge_p[:, None] + b[None, :, None] * edge_q[:, None]

    eye = np.eye(3)
    signs = (side[:, None, None] * eye[k][:, None, :]
             + a[None, :, None] * eye[p][:, None, :] + b[None, :, None] * eye[q][:, None, :])
    face = bf.face_id(k, side < 0)
    del n
    return vertices, signs, face


def _clip_candidates(quad, depth, half_u, half_w, tol):
    """Candidate manifold points in the reference plane (closed-form quad/rectangle clip).

    Parameters
    ----------
    quad : ndarray, shape (n, 4, 2)
        Incident quad projected on the reference plane, (u, w) coordinates, cyclic order.
    depth : ndarray, shape (n, 4)
        Penetration depth of the quad vertices (metres).
    half_u, half_w : ndarray, shape (n,)
        Reference rectangle half-extents.
    tol : ndarray, shape (n,)
        Snap tolerance (metres).

    Returns
    -------
    points : ndarray, shape (n, 24, 2)
    depths : ndarray, shape (n, 24)
    valid : ndarray of bool, shape (n, 24)
    """
    half = np.stack([half_u, half_w], axis=1)  # (n, 2)
    # (a) quad vertices inside the rectangle, snapped onto it.
    inside_rect = np.all(np.abs(quad) <= (half + tol[:, None])[:, None, :], axis=2)
    vertex_points = np.clip(quad, -half[:, None, :], half[:, None, :])

    # (b) rectangle corners inside the parallelogram, unless on a quad vertex.
    corners = RECT_SIGNS[None] * half[:, None, :]  # (n, 4, 2)
    centre = quad.mean(axis=1)
    axis_a = 0.5 * (quad[:, 0] - quad[:, 1])  # half edge along the first in-plane axis
    axis_b = 0.5 * (quad[:, 1] - quad[:, 2])
    det = axis_a[:, 0] * axis_b[:, 1] - axis_a[:, 1] * axis_b[:, 0]
    rel = corners - centre[:, None, :]
    alpha = (rel[..., 0] * axis_b[:, None, 1] - rel[..., 1] * axis_b[:, None, 0]) / det[:, None]
    beta = (axis_a[:, None, 0] * rel[..., 1] - axis_a[:, None, 1] * rel[..., 0]) / det[:, None]
    len_a = np.linalg.norm(axis_a, axis=1)[:, None]
    len_b = np.linalg.norm(axis_b, axis=1)[:, None]
    inside_quad = ((np.abs(alpha) - 1.0) * len_a <= tol[:, None]) & (
        (np.abs(beta) - 1.0) * len_b <= tol[:, None])
    gap = np.linalg.norm(corners[:, :, None, :] - quad[:, None, :, :], axis=3).min(axis=2)
    corner_valid = inside_quad & (gap > tol[:, None])
    d_centre = depth.mean(axis=1)
    d_a = 0.5 * (depth[:, 0] - depth[:, 1])
    d_b = 0.5 * (depth[:, 1] - depth[:, 2])
    corner_depth = d_centre[:, None] + alpha * d_a[:, None] + beta * d_b[:, None]

    # (c) quad edges crossing the interior of a rectangle edge.
    start, end = quad, np.roll(quad, -1, axis=1)  # (n, 4, 2)
    d_start, d_end = depth, np.roll(depth, -1, axis=1)
    line_coord = np.array([0, 0, 1, 1])  # u = +-h_u, then w = +-h_w
    line_value = np.array([1.0, -1.0, 1.0, -1.0])[None] * half[:, line_coord]  # (n, 4)
    s0 = start[:, :, line_coord]  # (n, 4 edges, 4 lines)
    delta = end[:, :, line_coord] - s0
    other0 = start[:, :, 1 - line_coord]
    other_delta = end[:, :, 1 - line_coord] - other0
    safe = np.where(delta == 0.0, 1.0, delta)
    tau = (line_value[:, None, :] - s0) / safe
    edge_len = np.linalg.norm(end - start, axis=2)[:, :, None]
    other = other0 + tau * other_delta
    other_half = half[:, 1 - line_coord][:, None, :]
    cross_valid = ((delta != 0.0) & (tau * edge_len > tol[:, None, None])
                   & ((1.0 - tau) * edge_len > tol[:, None, None])
                   & (np.abs(other) < other_half - tol[:, None, None]))
    cross_points = np.empty(tau.shape + (2,))
    cross_points[..., 0] = np.where(line_coord == 0, line_value[:, None, :], other)
    cross_points[..., 1] = np.where(line_coord == 1, line_value[:, None, :], other)
    cross_depth = d_start[:, :, None] + tau * (d_end - d_start)[:, :, None]

    n = quad.shape[0]
    points = np.concatenate([vertex_points, corners, cross_points.reshape(n, 16, 2)], axis=1)
    depths = np.concatenate([depth, corner_depth, cross_depth.reshape(n, 16)], axis=1)
    valid = np.concatenate([inside_rect, corner_valid, cross_valid.reshape(n, 16)], axis=1)
    return points, depths, valid & (depths >= -tol[:, None])


def _incident_feature(depth, signs, face, tol):
    """Incident feature id from the number of penetrating quad vertices, shape (n,)."""
    order = np.argsort(-depth, axis=1, kind="stable")
    deepest = np.take_along_axis(signs, order[:, 0, None, None], axis=1)[:, 0]
    second = np.take_along_axis(signs, order[:, 1, None, None], axis=1)[:, 0]
    touching = (depth >= -tol[:, None]).sum(axis=1)
    vertex = bf.vertex_id(deepest[:, 0] < 0, deepest[:, 1] < 0, deepest[:, 2] < 0)
    along = np.argmax(deepest != second, axis=1)
    j = np.where(along == 0, 1, 0)
    m = np.where(along == 2, 1, 2)
    edge = bf.edge_id(along, _gather(deepest, j) < 0, _gather(deepest, m) < 0)
    feature = np.where(touching >= 3, face, np.where(touching == 2, edge, vertex))
    return feature, np.minimum(np.maximum(touching, 1), 3)


def face_manifold(half_ref, half_inc, rot_ri, t_ri, ref_axis, ref_sign, scale):
    """Clip the incident face against the reference face, for N face-axis contacts.

    Parameters
    ----------
    half_ref, half_inc : ndarray, shape (n, 3)
        Half-extents of the reference and incident boxes (metres).
    rot_ri : ndarray, shape (n, 3, 3)
        Incident box axes as columns in the reference frame.
    t_ri : ndarray, shape (n, 3)
        Incident box centre in the reference frame (metres).
    ref_axis : ndarray of int, shape (n,)
        Reference face axis (0-2); ``ref_sign`` (n,) its side (+-1), facing the incident box.
    scale : ndarray, shape (n,)
        Pair scale (metres) for the tolerances.

    Returns
    -------
    points : ndarray, shape (n, 8, 3)
        Mid-surface manifold points in the reference frame, deepest first, zero padded.
    depths : ndarray, shape (n, 8)
    count : ndarray of int, shape (n,)
    incident_feature : ndarray of int, shape (n,)
        Feature id in the incident box (vertex, edge or face).
    touching_rank : ndarray of int, shape (n,)
        1 vertex, 2 edge, 3 face: the kind of the incident feature.
    """
    tol = SNAP_TOL_REL * scale
    vertices, signs, face = incident_face(half_inc, rot_ri, t_ri, ref_axis, ref_sign)
    u, w = (ref_axis + 1) % 3, (ref_axis + 2) % 3
    height = _gather(half_ref, ref_axis)
    depth = height[:, None] - ref_sign[:, None] * _gather(vertices, np.repeat(ref_axis[:, None], 4, 1))
    quad = np.stack([_gather(vertices, np.repeat(u[:, None], 4, 1)),
                     _gather(vertices, np.repeat(w[:, None], 4, 1))], axis=2)
    points2, depths, valid = _clip_candidates(quad, depth, _gather(half_ref, u),
                                              _gather(half_ref, w), tol)

    key = np.where(valid, -depths, np.inf)
    order = np.argsort(key, axis=1, kind="stable")[:, :MAX_MANIFOLD_POINTS]
    keep = np.take_along_axis(valid, order, axis=1)
    depths = np.where(keep, np.take_along_axis(depths, order, axis=1), 0.0)
    points2 = np.take_along_axis(points2, order[:, :, None], axis=1)
    points = np.zeros(depths.shape + (3,))
    eye = np.eye(3)
    points += eye[ref_axis][:, None, :] * (ref_sign * height)[:, None, None]
    points -= eye[ref_axis][:, None, :] * (ref_sign[:, None] * 0.5 * depths)[:, :, None]
    points += eye[u][:, None, :] * points2[:, :, 0:1] + eye[w][:, None, :] * points2[:, :, 1:2]
    points *= keep[:, :, None]

    feature, rank = _incident_feature(depth, signs, face, tol)
    return points, depths, keep.sum(axis=1), feature, rank


def weighted_point(points, depths, count, scale):
    """Depth-weighted mean of the manifold points, shape (n, 3).

    Weights are ``max(depth, 0) + WEIGHT_FLOOR_REL * scale`` over the valid points, so the
    point moves continuously as a face tilts through parallel.
    """
    valid = np.arange(points.shape[1])[None, :] < count[:, None]
    weight = np.where(valid, np.maximum(depths, 0.0) + (WEIGHT_FLOOR_REL * scale)[:, None], 0.0)
    total = weight.sum(axis=1)
    return np.einsum("nk,nkc->nc", weight, points) / np.where(total > 0, total, 1.0)[:, None]


def edge_contact(half_a, half_b, rotation, translation, normal, axis):
    """Closest points of the supporting edges for N edge-edge contacts, in A's frame.

    Parameters
    ----------
    half_a, half_b : ndarray, shape (n, 3)
    rotation : ndarray, shape (n, 3, 3)
        B's axes as columns in A's frame.
    translation : ndarray, shape (n, 3)
        B's centre in A's frame.
    normal : ndarray, shape (n, 3)
        Unit normal from A towards B in A's frame.
    axis : ndarray of int, shape (n,)
        Cross axis ids (6-14).

    Returns
    -------
    point : ndarray, shape (n, 3)
        Midpoint of the two closest points (the mid-surface point), A's frame.
    edge_a, edge_b : ndarray of int, shape (n,)
        Feature ids of the two edges.
    """
    i, j = (axis - 6) // 3, (axis - 6) % 3
    eye = np.eye(3)
    sign_a = sign_nonnegative(normal)
    centre_a = half_a * sign_a * (1.0 - eye[i])
    normal_in_b = np.einsum("nij,ni->nj", rotation, normal)
    sign_b = -sign_nonnegative(normal_in_b)
    centre_b_local = half_b * sign_b * (1.0 - eye[j])
    centre_b = translation + np.einsum("nij,nj->ni", rotation, centre_b_local)
    dir_a, dir_b = eye[i], _column(rotation, j)

    offset = centre_b - centre_a
    cos = np.einsum("nc,nc->n", dir_a, dir_b)
    sine2 = np.einsum("nc,nc->n", np.cross(dir_a, dir_b), np.cross(dir_a, dir_b))
    proj_a = np.einsum("nc,nc->n", offset, dir_a)
    proj_b = np.einsum("nc,nc->n", offset, dir_b)
    safe = np.where(sine2 > 0, sine2, 1.0)
    s = np.clip((proj_a - cos * proj_b) / safe, -_gather(half_a, i), _gather(half_a, i))
    r = np.clip((cos * proj_a - proj_b) / safe, -_gather(half_b, j), _gather(half_b, j))
    closest_a = centre_a + s[:, None] * dir_a
    closest_b = centre_b + r[:, None] * dir_b
    point = 0.5 * (closest_a + closest_b)

    def others(k):
        return np.where(k == 0, 1, 0), np.where(k == 2, 1, 2)

    ja, la = others(i)
    edge_a = bf.edge_id(i, _gather(sign_a, ja) < 0, _gather(sign_a, la) < 0)
    jb, lb = others(j)
    edge_b = bf.edge_id(j, _gather(sign_b, jb) < 0, _gather(sign_b, lb) < 0)
    return point, edge_a, edge_b
