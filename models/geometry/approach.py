"""Exact first-touch placement of two boxes along an approach direction.

Setting (everything in A's frame, metres): box A with full edge lengths ``size_a`` sits at the
origin with identity orientation; box B (``size_b``) has orientation ``rotation_ab`` (B's axes
as the columns, expressed in A's frame) and its centre at ``s * direction``. We want the
largest ``s >= 0`` at which the boxes still touch, i.e. the distance at which B, coming in from
far away along ``direction``, first touches A.

Stages
------
1. Candidate axes: the separating-axis theorem (SAT) for two boxes needs 15 axes: A's three
   face normals ``e_i``, B's three face normals ``b_j`` (columns of ``rotation_ab``) and the
   nine edge-edge cross products ``c_ij = e_i x b_j``. They are kept unnormalised; every
   quantity below is homogeneous of degree one in the axis, so the norm cancels in ``r / |c.d|``.
2. Radii: the projected half-extent of both boxes on ``c``,
   ``r = sum_m ha_m |c . e_m| + sum_m hb_m |c . b_m|``. For a cross axis the six dot products
   are written with entries of ``rotation_ab`` directly (as in ODE's dBoxBox), so the two that
   vanish analytically are exactly zero instead of rounding noise.
3. Degenerate axes: a cross product of (nearly) parallel edges has length ``|c| = sin(angle)``
   below :data:`PARALLEL_EDGE_SINE` and is skipped; the face axes cover that case.
4. Touching distance: ``s_k = r_k / |c_k . d|``; an axis with ``c_k . d = 0`` never bounds
   ``s`` (``s_k = inf``). The answer is ``min_k s_k``.

The axis order (index ``k``) is the one of :mod:`impactnet.models.contacts`: 0-2 face normal i of A,
3-5 face normal j of B, ``6 + 3 i + j`` the cross product of A's edge i with B's edge j.
"""
from __future__ import annotations

import numpy as np

#: Dimensionless (sine of the angle between two edge directions). Cross products of edge
#: pairs closer to parallel than this are skipped as separating axes: their direction is
#: dominated by rounding, and for parallel edges the face axes already decide the overlap.
#: Skipping a nearly degenerate axis can only make ``touching_distance`` larger, by at most
#: about ``PARALLEL_EDGE_SINE`` times the longest edge (1e-10 m for a 100 m box).
PARALLEL_EDGE_SINE = 1e-12

#: The two other axes of each axis i (ascending), used to build the cross-axis terms.
_OTHER = np.array([[1, 2], [0, 2], [0, 1]])

#: Number of SAT axes for a pair of boxes.
N_AXES = 15


def _as_rows(x, width):
    """Broadcastable array-like -> float64 array of shape (n, width) (n >= 1)."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[None, :]
    if a.shape[-1] != width:
        raise ValueError(f"expected trailing dimension {width}, got shape {a.shape}")
    return a


def _broadcast_rows(size_a, size_b, rotation_ab, vector):
    """Bring sizes (n,3), rotations (n,3,3) and a vector (n,3) to one row count n."""
    size_a, size_b, vector = _as_rows(size_a, 3), _as_rows(size_b, 3), _as_rows(vector, 3)
    rot = np.asarray(rotation_ab, dtype=np.float64)
    if rot.ndim == 2:
        rot = rot[None]
    n = np.broadcast_shapes(size_a.shape[:1], size_b.shape[:1], rot.shape[:1], vector.shape[:1])
    return (np.broadcast_to(size_a, n + (3,)), np.broadcast_to(size_b, n + (3,)),
            np.broadcast_to(rot, n + (3, 3)), np.broadcast_to(vector, n + (3,)))


def axis_terms(size_a, size_b, rotation_ab):
    """Unnormalised SAT axes, radii and axis lengths of N box pairs, in A's frame.

    Parameters
    ----------
    size_a, size_b : array_like, shape (n, 3) or (3,)
        Full edge lengths of A and B in metres (> 0).
    rotation_ab : array_like, shape (n, 3, 3) or (3, 3)
        Rotation of B relative to A: B's axes as the columns, in A's frame.

    Returns
    -------
    axes : ndarray, shape (n, 15, 3)
        Unnormalised axes ``c_k`` in A's frame (dimensionless); see the module docstring for
        the order.
    radius : ndarray, shape (n, 15)
        ``r_k = sum of the projected half-extents of A and B on c_k`` in metres times
        ``|c_k|`` (divide by ``length`` for the radius on the unit axis).
    length : ndarray, shape (n, 15)
        ``|c_k|`` (1 for face axes, the sine of the edge angle for cross axes).
    valid : ndarray of bool, shape (n, 15)
        False for cross axes of edges parallel within :data:`PARALLEL_EDGE_SINE`.
    """
    ha = 0.5 * _as_rows(size_a, 3)
    hb = 0.5 * _as_rows(size_b, 3)
    rot = np.asarray(rotation_ab, dtype=np.float64)
    if rot.ndim == 2:
        rot = rot[None]
    n = max(ha.shape[0], hb.shape[0], rot.shape[0])
    ha, hb = np.broadcast_to(ha, (n, 3)), np.broadcast_to(hb, (n, 3))
    rot = np.broadcast_to(rot, (n, 3, 3))
    q = np.abs(rot)

    # Face axes of A (e_i) and of B (b_j, the columns of rot).
    eye = np.broadcast_to(np.eye(3), (n, 3, 3))
    face_a_r = ha + np.einsum("nij,nj->ni", q, hb)  # ha_i + sum_j |R_ij| hb_j
    face_b_r = hb + np.einsum("nij,ni->nj", q, ha)  # hb_j + sum_i |R_ij| ha_i

    # Cross axes c_ij = e_i x b_j, flattened as k = 3 i + j.
    i_idx, j_idx = np.divmod(np.arange(9), 3)
    i1, i2 = _OTHER[i_idx, 0], _OTHER[i_idx, 1]
    j1, j2 = _OTHER[j_idx, 0], _OTHER[j_idx, 1]
    cross = np.cross(eye[:, i_idx, :], np.swapaxes(rot, 1, 2)[:, j_idx, :])  # (n, 9, 3)
    # |c.e_i1| = |R[i2, j]|, |c.e_i2| = |R[i1, j]|; |c.b_j1| = |R[i, j2]|, |c.b_j2| = |R[i, j1]|.
    cross_r = (
        ha[:, i1] * q[:, i2, j_idx]
        + ha[:, i2] * q[:, i1, j_idx]
        + hb[:, j1] * q[:, i_idx, j2]
        + hb[:, j2] * q[:, i_idx, j1]
    )
    cross_len = np.hypot(rot[:, i1, j_idx], rot[:, i2, j_idx])

    axes = np.concatenate([eye, np.swapaxes(rot, 1, 2), cross], axis=1)
    radius = np.concatenate([face_a_r, face_b_r, cross_r], axis=1)
    length = np.concatenate([np.ones((n, 6)), cross_len], axis=1)
    valid = length >= PARALLEL_EDGE_SINE
    return axes, radius, length, valid


def axis_overlaps(size_a, size_b, rotation_ab, offset):
    """Signed SAT overlap of N box pairs on each of the 15 unit axes.

    Parameters
    ----------
    size_a, size_b : array_like, shape (n, 3) or (3,)
        Full edge lengths in metres.
    rotation_ab : array_like, shape (n, 3, 3) or (3, 3)
        B's axes as columns in A's frame.
    offset : array_like, shape (n, 3) or (3,)
        Centre of B minus centre of A, in A's frame, metres.

    Returns
    -------
    ndarray, shape (n, 15)
        ``r_k - |n_k . offset|`` in metres on the unit axis ``n_k``: >= 0 where the
        projections overlap, < 0 where the axis separates the boxes. Skipped (degenerate)
        axes are ``+inf``. The boxes overlap iff every entry is >= 0.
    """
    size_a, size_b, rotation_ab, t = _broadcast_rows(size_a, size_b, rotation_ab, offset)
    axes, radius, length, valid = axis_terms(size_a, size_b, rotation_ab)
    proj = np.abs(np.einsum("nkc,nc->nk", axes, t))
    with np.errstate(divide="ignore", invalid="ignore"):
        overlap = (radius - proj) / length
    return np.where(valid, overlap, np.inf)


def touching_distance(size_a, size_b, rotation_ab, direction, return_axis=False):
    """Largest ``s >= 0`` at which B, centred at ``s * direction``, touches A.

    A is at the origin with identity orientation, B has orientation ``rotation_ab``; all
    vectors are in A's frame.

    Why this is exact: two convex boxes overlap iff their projections overlap on every one of
    the 15 SAT axes ``n_k`` (3 face normals of A, 3 of B, 9 edge cross products: two
    disjoint convex polytopes always have a separating plane parallel to a face of one of
    them or to an edge of each, and a box's faces and edges have only 3 directions). With B's
    centre at ``s d`` the overlap condition on axis ``k`` is ``|n_k . d| s <= r_k``, where
    ``r_k`` is the sum of the projected half-extents (independent of ``s``). Each condition
    holds on the interval ``s <= r_k / |n_k . d|`` (all ``s`` when ``n_k . d = 0``), so the set
    of overlapping ``s >= 0`` is ``[0, min_k r_k / |n_k . d|]`` and its right end is the first
    touch. The boxes overlap at ``s = 0`` (same centre), so the minimum is finite and > 0.

    Parameters
    ----------
    size_a, size_b : array_like, shape (n, 3) or (3,)
        Full edge lengths of A and B in metres (> 0).
    rotation_ab : array_like, shape (n, 3, 3) or (3, 3)
        B's axes as columns in A's frame (a rotation matrix).
    direction : array_like, shape (n, 3) or (3,)
        Unit approach direction in A's frame (dimensionless).
    return_axis : bool, optional
        Also return the index (0-14) of the binding axis.

    Returns
    -------
    s : ndarray, shape (n,)
        Touching distance in metres (centre-to-centre along ``direction``).
    axis : ndarray of int, shape (n,)
        Only if ``return_axis``: index of the axis that binds (smallest ``r_k / |n_k . d|``).
    """
    size_a, size_b, rotation_ab, d = _broadcast_rows(size_a, size_b, rotation_ab, direction)
    axes, radius, _, valid = axis_terms(size_a, size_b, rotation_ab)
    proj = np.abs(np.einsum("nkc,nc->nk", axes, d))
    usable = valid & (proj > 0.0)
    # Unnormalised r and c.d share the factor |c|, so r / |c.d| is the distance on the unit
    # axis. Axes perpendicular to the direction (c.d == 0) or degenerate never bind.
    s_k = np.full(radius.shape, np.inf)
    with np.errstate(over="ignore"):  # a tiny |c.d| gives inf: that axis never binds
        np.divide(radius, proj, out=s_k, where=usable)
    axis = np.argmin(s_k, axis=1)
    s = np.take_along_axis(s_k, axis[:, None], axis=1)[:, 0]
    return (s, axis) if return_axis else s
