"""Geometry of the centre-of-pressure reference: which face, and where to integrate.

Part of :mod:`impactnet.training.bench.accuracy.cop_reference` (see its docstring): the choice of
the reference face (:func:`reference_faces`), the pair seen from the reference box
(:func:`reference_frame`), the grid's rectangle (:func:`support_points`, :func:`grid_frame`) and the
slabs that bound the integrand (:func:`constraints`). Plain NumPy and SciPy; nothing from
``models``.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

#: Floor of an incident slab's rate along the face normal (dimensionless): a slab parallel to
#: the normal (rate 0, a face exactly perpendicular to the reference face) becomes a slab of
#: rate 1e-300, i.e. entry and exit at +-1e300-scale distances: all or nothing, as the limit.
MIN_RATE = 1e-300
#: The 8 corners of a box as signs along its axes, and its 12 edges as corner index pairs.
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
_EDGES = np.array([(i, j) for i in range(8) for j in range(i + 1, 8)
                   if np.abs(_CORNERS[i] - _CORNERS[j]).sum() == 2])


def _matrices(quaternion: np.ndarray) -> np.ndarray:
    """(n, 4) quaternions (w, x, y, z), any norm > 0 -> (n, 3, 3) rotation matrices."""
    return Rotation.from_quat(quaternion, scalar_first=True).as_matrix()


def reference_faces(normal, rot_a, rot_b):
    """The face best aligned with ``normal``: A's with +normal or B's with -normal.

    Parameters
    ----------
    normal : ndarray, shape (n, 3)
        Unit contact normals from A towards B (world frame).
    rot_a, rot_b : ndarray, shape (n, 3, 3)
        Rotation matrices of A and B (box axes as columns).

    Returns
    -------
    ref_is_b : ndarray of bool, shape (n,)
    axis : ndarray of int, shape (n,)
        Face axis (0-2) in the reference box's frame.
    sign : ndarray, shape (n,)
        +-1, the face's side along that axis (its outward normal is ``sign * R[:, axis]``).
    alignment : ndarray, shape (n,)
        Cosine between the face's outward normal and +normal (A) or -normal (B).
    """
    dot_a = np.einsum("nij,ni->nj", rot_a, normal)  # A's axes . n
    dot_b = -np.einsum("nij,ni->nj", rot_b, normal)  # B's axes . (-n)
    axis_a, axis_b = np.abs(dot_a).argmax(axis=1), np.abs(dot_b).argmax(axis=1)
    rows = np.arange(len(normal))
    best_a, best_b = dot_a[rows, axis_a], dot_b[rows, axis_b]
    ref_is_b = np.abs(best_b) > np.abs(best_a)
    axis = np.where(ref_is_b, axis_b, axis_a)
    best = np.where(ref_is_b, best_b, best_a)
    return ref_is_b, axis, np.where(best >= 0.0, 1.0, -1.0), np.abs(best)


def support_points(t, rot, half_inc, half_ref, k, sign):
    """Points whose hull projects onto the footprint before clipping, in face coordinates.

    The incident box's part beyond the reference plane is the hull of its vertices beyond the
    plane and of its edges' crossings with the plane. Returns ``points`` (m, 20, 2), the (u, w)
    coordinates of the 8 vertices and the 12 edge crossings (u, w = k + 1, k + 2 mod 3), and
    ``valid`` (m, 20) bool, which of them exist.
    """
    m = len(t)
    rows = np.arange(m)
    vertices = t[:, None, :] + np.einsum("nij,nkj->nki", rot, _CORNERS * half_inc[:, None, :])
    height = sign[:, None] * vertices[rows, :, k] - half_ref[rows, k][:, None]
    z0, z1 = height[:, _EDGES[:, 0]], height[:, _EDGES[:, 1]]
    crosses = z0 * z1 < 0.0
    tau = np.where(crosses, z0 / np.where(crosses, z0 - z1, 1.0), 0.0)[..., None]
    crossing = vertices[:, _EDGES[:, 0]] + tau * (vertices[:, _EDGES[:, 1]]
                                                  - vertices[:, _EDGES[:, 0]])
    points = np.concatenate([vertices, crossing], axis=1)  # (m, 20, 3)
    uw = np.stack([points[rows, :, (k + 1) % 3], points[rows, :, (k + 2) % 3]], axis=-1)
    return uw, np.concatenate([height <= 0.0, crosses], axis=1)


def clipped_points(points, valid, half_u, half_w, corner_inside):
    """Points of the footprint clipped to the reference face, whose hull is the clipped hull.

    The clipped polygon's vertices are support points inside the face, face corners inside the
    footprint (``corner_inside`` (m, 4), corners in the order (+, +), (-, +), (-, -), (+, -)),
    and crossings of hull edges with the face's edges; every segment between two support points
    lies in the hull, so its crossings with the face's edges are used (a superset).

    Returns ``candidates`` (m, K, 2) in face coordinates and ``usable`` (m, K) bool.
    """
    m = len(points)
    half = np.stack([half_u, half_w], axis=1)  # (m, 2)
    inside = valid & (np.abs(points) <= half[:, None, :]).all(axis=2)
    corners = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]) * half[:, None, :]
    i, j = np.triu_indices(points.shape[1], 1)
    p, q = points[:, i], points[:, j]  # (m, pairs, 2)
    pair_ok = valid[:, i] & valid[:, j]
    crossings, ok = [], []
    for c in range(2):  # lines u = +-h_u (c = 0), w = +-h_w (c = 1)
        for side in (1.0, -1.0):
            line = side * half[:, c, None]
            step = q[..., c] - p[..., c]
            with np.errstate(divide="ignore", invalid="ignore"):  # parallel: tau inf / NaN
                tau = (line - p[..., c]) / step
                other = p[..., 1 - c] + tau * (q[..., 1 - c] - p[..., 1 - c])
            point = np.empty(p.shape)
            point[..., c], point[..., 1 - c] = np.broadcast_to(line, tau.shape), other
            crossings.append(point)
            ok.append(pair_ok & (tau >= 0.0) & (tau <= 1.0)
                      & (np.abs(other) <= half[:, 1 - c, None]))
    candidates = np.concatenate([points, corners] + crossings, axis=1)
    usable = np.concatenate([inside, corner_inside] + ok, axis=1)
    return np.where(usable[..., None], candidates, 0.0).reshape(m, -1, 2), usable


def grid_frame(points, valid, clipped, usable):
    """The grid's axes and extents.

    Axes: those of the minimum-area bounding rectangle of the support points (a minimum-area
    rectangle has a side along an edge of the hull, so the candidate directions are those of
    every pair of valid points). Extents: those of the clipped footprint along these axes
    (:func:`clipped_points`), so that a sliver of the footprint inside the face fills the grid.

    Returns ``e1``, ``e2`` (m, 2) (orthonormal, in face coordinates), ``low``, ``high`` (m, 2)
    (extents along e1 and e2, metres; ``low > high`` where the footprint is empty).
    """
    i, j = np.triu_indices(points.shape[1], 1)
    delta = points[:, j] - points[:, i]  # (m, pairs, 2)
    length = np.hypot(delta[..., 0], delta[..., 1])
    pair_ok = valid[:, i] & valid[:, j] & (length > 0.0)
    d1 = delta / np.where(pair_ok, length, 1.0)[..., None]
    along = np.einsum("npc,nkc->npk", d1, points)  # (m, pairs, 20)
    across = d1[..., 0, None] * points[:, None, :, 1] - d1[..., 1, None] * points[:, None, :, 0]
    mask = valid[:, None, :]
    area = ((np.where(mask, along, -np.inf).max(-1) - np.where(mask, along, np.inf).min(-1))
            * (np.where(mask, across, -np.inf).max(-1) - np.where(mask, across, np.inf).min(-1)))
    best = np.where(pair_ok, area, np.inf).argmin(axis=1)
    rows = np.arange(len(points))
    e1 = np.where(pair_ok.any(axis=1)[:, None], d1[rows, best], [1.0, 0.0])
    e2 = np.stack([-e1[:, 1], e1[:, 0]], axis=1)
    low, high = np.empty((len(points), 2)), np.empty((len(points), 2))
    for c, axis in enumerate((e1, e2)):
        coord = np.einsum("nkc,nc->nk", clipped, axis)
        low[:, c] = np.where(usable, coord, np.inf).min(axis=1)
        high[:, c] = np.where(usable, coord, -np.inf).max(axis=1)
    return e1, e2, low, high


def constraints(t, rot, half_inc, half_ref, k, sign, e1, e2) -> np.ndarray:
    """The slabs that bound the integrand, as functions of the grid coordinates, (5, 5, m).

    For the plane point at grid coordinates (a, b), i.e. face coordinates ``a e1 + b e2``:

    * slabs 0-2, the incident box's (axis j): the line through the point along the face's
      outward normal enters and leaves the slab at ``q -+ r``, ``q = c0 + a ca + b cb``;
      rows c0, ca, cb, r (metres along the normal) and 1 (a flag);
    * slabs 3-4, the reference face's side planes (u, then w), parallel to the normal: the
      point is inside when ``|c0 + a ca + b cb| <= r``; the flag row is 0.

    An incident slab parallel to the normal has its rate floored at :data:`MIN_RATE`, which
    turns its entry and exit into +-1e300-scale numbers of the right signs (all or nothing).
    """
    rows = np.arange(len(t))
    height = sign * half_ref[rows, k]
    coef = np.zeros((5, 5, len(t)))
    for j in range(3):
        col = rot[:, :, j]  # incident axis j in the reference frame
        rate = sign * col[rows, k]  # d (coordinate j) / d (distance along the normal)
        rate = np.where(rate < 0.0, -1.0, 1.0) * np.maximum(np.abs(rate), MIN_RATE)
        cu, cw = col[rows, (k + 1) % 3], col[rows, (k + 2) % 3]
        coef[0, j] = -(height * col[rows, k] - np.einsum("ni,ni->n", col, t)) / rate
        coef[1, j] = -(cu * e1[:, 0] + cw * e1[:, 1]) / rate
        coef[2, j] = -(cu * e2[:, 0] + cw * e2[:, 1]) / rate
        coef[3, j], coef[4, j] = half_inc[:, j] / np.abs(rate), 1.0
    for c in range(2):  # u = a e1[0] + b e2[0], w = a e1[1] + b e2[1]
        coef[1, 3 + c], coef[2, 3 + c] = e1[:, c], e2[:, c]
        coef[3, 3 + c] = half_ref[rows, (k + 1 + c) % 3]
    return coef


def reference_frame(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                    normal):
    """The pairs seen from their reference boxes (the face best aligned with ``normal``).

    Inputs as :func:`centre_of_pressure`. Returns ``centre_r`` (n, 3) and ``rot_r`` (n, 3, 3),
    the reference box's centre and axes (world); ``t`` (n, 3) and ``rot`` (n, 3, 3), the
    incident box's centre and axes in the reference frame; ``half_i``, ``half_r`` (n, 3)
    half-extents (metres); ``axis`` (n,), ``sign`` (n,) and ``ref_is_b`` (n,) from
    :func:`reference_faces`.
    """
    arrays = [np.asarray(x, np.float64).reshape(-1, w) for x, w in zip(
        (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, normal),
        (3, 3, 4, 3, 3, 4, 3))]
    n = max(len(a) for a in arrays)
    sa, pa, qa, sb, pb, qb, nrm = (np.broadcast_to(a, (n, a.shape[1])) for a in arrays)
    rot_a, rot_b = _matrices(qa), _matrices(qb)
    ref_is_b, axis, sign, _ = reference_faces(nrm, rot_a, rot_b)
    flip, flip3 = ref_is_b[:, None], ref_is_b[:, None, None]
    centre_r, centre_i = np.where(flip, pb, pa), np.where(flip, pa, pb)
    rot_r, rot_i = np.where(flip3, rot_b, rot_a), np.where(flip3, rot_a, rot_b)
    half_r, half_i = 0.5 * np.where(flip, sb, sa), 0.5 * np.where(flip, sa, sb)
    t = np.einsum("nji,nj->ni", rot_r, centre_i - centre_r)  # R_r^T (c_i - c_r)
    rot = np.einsum("nji,njk->nik", rot_r, rot_i)  # R_r^T R_i
    return centre_r, rot_r, t, rot, half_i, half_r, axis, sign, ref_is_b


def depth_at(coef, a, b) -> np.ndarray:
    """``d = max(-s_in, 0)`` at grid points (a, b) (slab method); 0 where the line misses.

    ``coef`` (5, 5, ...) from :func:`constraints` broadcasts against ``a`` and ``b``.
    """
    entry, leave, inside = -np.inf, np.inf, True
    for j in range(3):
        q = (coef[0, j] + a * coef[1, j]) + b * coef[2, j]
        entry = np.maximum(entry, q - coef[3, j])
        leave = np.minimum(leave, q + coef[3, j])
    for j in (3, 4):
        inside = inside & (np.abs((coef[0, j] + a * coef[1, j]) + b * coef[2, j]) <= coef[3, j])
    return np.where(inside & (entry <= leave), np.maximum(-entry, 0.0), 0.0)
