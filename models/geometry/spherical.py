"""Spherical angles of directions: the paper's output format (NumPy only; serving uses it).

Conventions
-----------
* ``azimuth = atan2(y, x)`` in [-pi, pi] (the seam is the half-plane ``y = 0, x < 0``; a signed
  zero ``y = -0.0`` is read as ``+0.0``, so the seam itself gives ``+pi``).
* ``elevation = atan2(z, hypot(x, y))`` in [-pi/2, pi/2], measured from the xy-plane.
* At the poles (``x = y = 0``) the azimuth is undefined; :func:`to_spherical` returns 0 there,
  and :func:`from_spherical` ignores it (any finite azimuth gives the pole).
* Angle *errors* are compared after :func:`wrap_angle`, which maps any angle into [-pi, pi),
  so that a label of ``+pi`` and a prediction of ``-pi`` count as equal.

The paper's four outputs (:func:`paper_angles`): azimuth and elevation of the impact point's
direction seen from A's centre, then azimuth and elevation of the force direction (the contact
normal, from A towards B), both in A's body frame. The point's distance from A's centre is not
an output: it follows from the direction, since the point lies on A's surface
(:func:`ray_to_box_surface`).
"""
from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def _vectors(v, field="v"):
    """``v`` as float64 ``(n, 3)``; a single ``(3,)`` vector is a batch of one."""
    a = np.asarray(v, dtype=np.float64)
    if a.shape == (3,):
        a = a[None]
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{field}: expected shape (3,) or (n, 3), got {np.shape(v)}")
    return a


def wrap_angle(a):
    """Angles wrapped into [-pi, pi) (radians, any shape; NaN stays NaN).

    ``wrap_angle(a) - a`` is a multiple of 2 pi, and angles already in [-pi, pi) are returned
    unchanged. ``np.mod`` of a tiny negative number can round up to exactly 2 pi, which would
    give +pi; that case is folded back to -pi.
    """
    a = np.asarray(a, dtype=np.float64)
    wrapped = np.mod(a + np.pi, TWO_PI) - np.pi
    return np.where(wrapped >= np.pi, wrapped - TWO_PI, wrapped)


def to_spherical(v):
    """Azimuth and elevation of directions.

    Parameters
    ----------
    v : array_like, shape (3,) or (n, 3)
        Vectors of any norm > 0 (finite).

    Returns
    -------
    azimuth, elevation : ndarray, shape (n,)
        Radians; azimuth in [-pi, pi] (0 at the poles), elevation in [-pi/2, pi/2].

    Raises
    ------
    ValueError
        Wrong shape, a non-finite entry or a zero vector (no direction).
    """
    a = _vectors(v)
    bad = ~np.isfinite(a).all(axis=1) | ~(a != 0).any(axis=1)  # no norm: 1e-300 would underflow
    if bad.any():
        raise ValueError(f"v: zero or non-finite vectors at rows {np.flatnonzero(bad)[:10]}")
    x, y, z = (a[:, i] + 0.0 for i in range(3))  # + 0.0 turns -0.0 into +0.0
    return np.arctan2(y, x), np.arctan2(z, np.hypot(x, y))


def from_spherical(azimuth, elevation):
    """Unit vectors ``(n, 3)`` of azimuths and elevations (radians, broadcast to shape (n,)).

    Any finite angles are accepted (they need not be wrapped); the inverse of
    :func:`to_spherical` up to round-off.
    """
    az, el = np.broadcast_arrays(np.atleast_1d(np.asarray(azimuth, dtype=np.float64)),
                                 np.atleast_1d(np.asarray(elevation, dtype=np.float64)))
    cos_el = np.cos(el)
    return np.stack([cos_el * np.cos(az), cos_el * np.sin(az), np.sin(el)], axis=-1).reshape(-1, 3)


def _rotations(rotation, n):
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape == (3, 3):
        r = r[None]
    if r.ndim != 3 or r.shape[1:] != (3, 3) or r.shape[0] not in (1, n):
        raise ValueError(f"rotation_a: expected (3, 3) or ({n}, 3, 3), got {np.shape(rotation)}")
    return np.broadcast_to(r, (n, 3, 3))


def paper_angles(point, normal, position_a, rotation_a):
    """The paper's four output angles of N contacts.

    Parameters
    ----------
    point : array_like, shape (3,) or (n, 3)
        Impact points in the world frame (metres); must differ from A's centre.
    normal : array_like, shape (3,) or (n, 3)
        Force directions (contact normals from A towards B) in the world frame, any norm > 0.
    position_a : array_like, shape (3,) or (n, 3)
        A's centre in the world frame (metres).
    rotation_a : array_like, shape (3, 3) or (n, 3, 3)
        A's orientation (``v_world = R @ v_body``).

    Returns
    -------
    ndarray, shape (n, 4)
        ``[point azimuth, point elevation, force azimuth, force elevation]`` in radians, in A's
        frame; azimuths in [-pi, pi], elevations in [-pi/2, pi/2].
    """
    p, nrm = _vectors(point, "point"), _vectors(normal, "normal")
    pa = _vectors(position_a, "position_a")
    n = max(len(p), len(nrm), len(pa))
    rot = _rotations(rotation_a, n)
    local_point = np.einsum("nji,nj->ni", rot, np.broadcast_to(p - pa, (n, 3)))
    local_normal = np.einsum("nji,nj->ni", rot, np.broadcast_to(nrm, (n, 3)))
    return np.column_stack([*to_spherical(local_point), *to_spherical(local_normal)])


def ray_to_box_surface(direction, size):
    """Where rays from a box's centre leave the box: points ``(n, 3)`` in the box frame.

    ``direction`` (3,) or (n, 3): directions in the box frame, any norm > 0; ``size`` (3,) or
    (n, 3): full edge lengths in metres. The point is ``s d`` with the smallest ``s > 0`` at
    which one coordinate reaches its half-extent.
    """
    d = _vectors(direction, "direction")
    half = 0.5 * np.broadcast_to(np.asarray(size, dtype=np.float64), d.shape)
    reach = np.max(np.abs(d) / half, axis=1)
    if not np.all(reach > 0):  # a zero vector, or one so small that the ratio underflows
        raise ValueError("direction: zero vectors have no surface point")
    return d / reach[:, None]
