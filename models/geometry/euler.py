"""Euler angles (radians, conventions ``"zyx"`` and ``"xyz"``, see
:mod:`impactnet.models.geometry.rotations`) to and from rotation matrices and quaternions,
vectorised over n rows, float64."""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.quaternions import quaternion_multiply
from impactnet.models.geometry.rotation_rows import InvalidRotationError, as_rows, canonical_sign

#: cos(pitch) below which matrix_to_euler treats the matrix as gimbal-locked (dimensionless).
#: Well above the ~1e-16 roundoff of cos(pitch) at exactly pitch = +-pi/2, small enough that
#: setting roll to 0 there perturbs the reproduced matrix by at most pi * 1e-12.
GIMBAL_LOCK_TOL = 1e-12

EULER_CONVENTIONS = ("zyx", "xyz")


def _axis_rotations(angles, axis):
    """``(n, 3, 3)`` rotations by ``angles`` (n,) radians about coordinate axis 0, 1 or 2."""
    c, s = np.cos(angles), np.sin(angles)
    j, k = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.zeros(angles.shape + (3, 3))
    out[:, axis, axis] = 1.0
    out[:, j, j], out[:, j, k], out[:, k, j], out[:, k, k] = c, -s, s, c
    return out


def _check_convention(convention):
    if convention not in EULER_CONVENTIONS:
        raise InvalidRotationError(
            "euler_convention", [], f"{convention!r} is not one of {EULER_CONVENTIONS}")


def euler_to_matrix(e, convention="zyx"):
    """Rotation matrices of Euler angles.

    Parameters
    ----------
    e : array_like, shape (3,) or (n, 3)
        Angles in radians: ``[roll, pitch, yaw]`` for ``"zyx"``, ``[a, b, c]`` for ``"xyz"``.
    convention : {"zyx", "xyz"}
        ``"zyx"``: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (default, impactnet's reading of the
        paper, whose protocol draws each angle uniform in [-pi/2, pi/2]);
        ``"xyz"``: ``R = Rx(a) @ Ry(b) @ Rz(c)``.

    Returns
    -------
    numpy.ndarray, shape (n, 3, 3)
    """
    _check_convention(convention)
    a = as_rows(e, (3,), "euler")
    rx, ry, rz = (_axis_rotations(a[:, i], i) for i in range(3))
    return rz @ ry @ rx if convention == "zyx" else rx @ ry @ rz


def euler_to_quaternion(e, convention="zyx"):
    """Unit quaternions ``(n, 4)``, canonical ``w >= 0``, of Euler angles ``(3,)`` or ``(n, 3)``
    in radians; ``convention`` as in :func:`euler_to_matrix`."""
    _check_convention(convention)
    half = 0.5 * as_rows(e, (3,), "euler")
    zero = np.zeros_like(half[:, 0])
    c, s = np.cos(half), np.sin(half)
    qx = np.stack([c[:, 0], s[:, 0], zero, zero], -1)
    qy = np.stack([c[:, 1], zero, s[:, 1], zero], -1)
    qz = np.stack([c[:, 2], zero, zero, s[:, 2]], -1)
    if convention == "zyx":
        q = quaternion_multiply(quaternion_multiply(qz, qy), qx)
    else:
        q = quaternion_multiply(quaternion_multiply(qx, qy), qz)
    return canonical_sign(q)


def matrix_to_euler(R, convention="zyx"):
    """Euler angles of rotation matrices; ``euler_to_matrix`` of the result reproduces ``R``.

    Pitch comes from ``atan2(-R20, hypot(R00, R10))`` and roll from ``atan2(R21, R22)``; yaw is
    then taken from ``R @ Rx(roll)^T`` (M. Day's method), so the angles reproduce ``R`` to
    roundoff also close to gimbal lock. At gimbal lock (``cos(pitch) < GIMBAL_LOCK_TOL``)
    pitch is set to exactly +-pi/2, roll to 0 and yaw carries the rest.

    Parameters
    ----------
    R : array_like, shape (3, 3) or (n, 3, 3)
        Rotation matrices (not checked; see :func:`validate_matrix`).
    convention : {"zyx", "xyz"}
        ``"zyx"`` returns ``[roll, pitch, yaw]``; ``"xyz"`` returns ``[a, b, c]`` with
        b in [-pi/2, pi/2] (a = 0 at gimbal lock), from the ``"zyx"`` angles of ``R^T``.

    Returns
    -------
    numpy.ndarray, shape (n, 3)
        Radians; pitch (b) in [-pi/2, pi/2], the other two in [-pi, pi].
    """
    _check_convention(convention)
    m = as_rows(R, (3, 3), "matrix")
    if convention == "xyz":     # R^T = Rz(-c) Ry(-b) Rx(-a): its "zyx" angles are -[a, b, c]
        return -matrix_to_euler(np.swapaxes(m, 1, 2), "zyx")
    cos_pitch = np.hypot(m[:, 0, 0], m[:, 1, 0])
    locked = cos_pitch < GIMBAL_LOCK_TOL
    pitch = np.where(locked, np.copysign(np.pi / 2, -m[:, 2, 0]),
                     np.arctan2(-m[:, 2, 0], cos_pitch))
    roll = np.where(locked, 0.0, np.arctan2(m[:, 2, 1], m[:, 2, 2]))
    c, s = np.cos(roll), np.sin(roll)
    # Column 1 of R @ Rx(roll)^T = Rz(yaw) @ Ry(pitch) is [-sin(yaw), cos(yaw), 0].
    yaw = np.arctan2(s * m[:, 0, 2] - c * m[:, 0, 1], c * m[:, 1, 1] - s * m[:, 1, 2])
    return np.stack([roll, pitch, yaw], axis=-1)
