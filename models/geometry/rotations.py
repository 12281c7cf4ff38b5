"""Rotations: quaternions, rotation matrices and Euler angles, vectorised over N rows, float64.

Conventions
-----------
* Active rotations: ``v_world = R @ v_body``; right-handed frames; angles in radians.
* Quaternions are ``[w, x, y, z]`` (Hamilton, scalar first); ``q`` and ``-q`` are the same
  rotation. Functions that *produce* a quaternion from a matrix or Euler angles return the
  canonical sign ``w >= 0``.
* Euler angles, default convention ``"zyx"``: ``euler = [roll, pitch, yaw]`` and
  ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (intrinsic z-y'-x'', the aerospace convention; equal to
  scipy's ``Rotation.from_euler("ZYX", [yaw, pitch, roll])``). :func:`matrix_to_euler` returns
  pitch in [-pi/2, pi/2] and roll, yaw in [-pi, pi]; at gimbal lock (``cos(pitch)`` below
  :data:`GIMBAL_LOCK_TOL`) roll is set to 0 and the whole remaining rotation goes into yaw.
* Alternative convention ``"xyz"``: ``euler = [a, b, c]`` and ``R = Rx(a) @ Ry(b) @ Rz(c)``
  (at gimbal lock ``a`` is set to 0). The paper (shared/paper.txt) never names its Euler
  convention; its protocol draws each angle uniform in [-pi/2, pi/2]. impactnet uses ``"zyx"``
  for it and offers ``"xyz"`` as the alternative reading.

Inputs broadcast: a single ``(4,)`` quaternion, ``(3,)`` Euler triple or ``(3, 3)`` matrix is a
batch of one; outputs always carry the leading ``n`` axis. The plain conversions assume valid
input (finite, unit quaternions, proper rotations); the ``validate_*`` and ``rotation_to_*``
functions check it and raise :class:`InvalidRotationError`.
"""
from __future__ import annotations

import numpy as np

#: Smallest accepted quaternion norm (dimensionless). Below it the quaternion is a zero
#: placeholder or the result of cancellation: normalising would amplify noise by > 1e6.
QUATERNION_MIN_NORM = 1e-6
#: Largest accepted max |R^T R - I| of an input matrix (dimensionless). Loose enough for
#: matrices stored in float32 (eps 6e-8) or printed with ~7 digits, tight enough to reject
#: any real shear or scale; accepted matrices are re-orthonormalised.
ROTATION_MATRIX_TOL = 1e-6
#: cos(pitch) below which matrix_to_euler treats the matrix as gimbal-locked (dimensionless).
#: Well above the ~1e-16 roundoff of cos(pitch) at exactly pitch = +-pi/2, small enough that
#: setting roll to 0 there perturbs the reproduced matrix by at most pi * 1e-12.
GIMBAL_LOCK_TOL = 1e-12

EULER_CONVENTIONS = ("zyx", "xyz")


class InvalidRotationError(ValueError):
    """An orientation input that is not a rotation.

    Attributes
    ----------
    field : str
        The offending input, e.g. ``"quaternion"``, ``"matrix"``, ``"euler"``, ``"orientation"``.
    rows : numpy.ndarray of int
        Indices of the offending rows (empty when the whole input is malformed).
    """

    def __init__(self, field, rows, reason):
        self.field = field
        self.rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        shown = ", ".join(str(int(i)) for i in self.rows[:10])
        more = f" (+{self.rows.size - 10} more)" if self.rows.size > 10 else ""
        at = f" at rows [{shown}]{more}" if self.rows.size else ""
        super().__init__(f"invalid {field}: {reason}{at}")


def _rows(x, tail, field):
    """``x`` as a float64 array of shape ``(n, *tail)``; a single ``tail``-shaped value -> n = 1."""
    a = np.asarray(x, dtype=np.float64)
    if a.shape == tail:
        a = a[None]
    if a.ndim != len(tail) + 1 or a.shape[1:] != tail:
        want = f"{tail} or (n, {', '.join(map(str, tail))})"
        raise InvalidRotationError(field, [], f"expected shape {want}, got {np.shape(x)}")
    return a


def _canonical(q):
    """Rows of ``(n, 4)`` quaternions flipped to the canonical sign ``w >= 0``."""
    return q * np.where(q[:, :1] < 0.0, -1.0, 1.0)


def quaternion_matrix(w, x, y, z) -> tuple:
    """The one quaternion-to-matrix formula of impactnet: the 9 entries (row-major) of the
    rotation of a unit quaternion ``(w, x, y, z)``.

    Generic arithmetic: the components may be Python floats (the N = 1 paths) or arrays of any
    shape (the batch paths), and every path therefore rounds the same way.
    """
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    return (1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy),
            2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx),
            2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy))


def quaternion_to_matrix(q):
    """Rotation matrices of unit quaternions.

    Parameters
    ----------
    q : array_like, shape (4,) or (n, 4)
        Unit quaternions ``[w, x, y, z]`` (not checked; see :func:`validate_quaternion`).

    Returns
    -------
    numpy.ndarray, shape (n, 3, 3)
        ``R`` with ``v_world = R @ v_body``; ``q`` and ``-q`` give the same ``R``.
    """
    q = _rows(q, (4,), "quaternion")
    return np.stack(quaternion_matrix(*q.T), axis=-1).reshape(-1, 3, 3)


def matrix_to_quaternion(R):
    """Unit quaternions of rotation matrices, Shepperd's method without branches.

    Of the four candidates ``4 q_k q`` (k = w, x, y, z) the one with the largest ``|q_k|`` is
    taken (chosen by argmax over ``[trace, R00, R11, R22]``), so no division by a small number
    happens, also at 180-degree rotations; there (``w == 0``) the chosen candidate makes its
    largest component positive, so the sign is deterministic too.

    Parameters
    ----------
    R : array_like, shape (3, 3) or (n, 3, 3)
        Rotation matrices (not checked; see :func:`validate_matrix`).

    Returns
    -------
    numpy.ndarray, shape (n, 4)
        ``[w, x, y, z]``, unit norm, canonical sign ``w >= 0``.
    """
    m = _rows(R, (3, 3), "matrix")
    r = {(i, j): m[:, i, j] for i in range(3) for j in range(3)}
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    candidates = np.stack([
        np.stack([1 + trace, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]], -1),
        np.stack([r[2, 1] - r[1, 2], 1 + r[0, 0] - r[1, 1] - r[2, 2],
                  r[0, 1] + r[1, 0], r[0, 2] + r[2, 0]], -1),
        np.stack([r[0, 2] - r[2, 0], r[0, 1] + r[1, 0],
                  1 - r[0, 0] + r[1, 1] - r[2, 2], r[1, 2] + r[2, 1]], -1),
        np.stack([r[1, 0] - r[0, 1], r[0, 2] + r[2, 0],
                  r[1, 2] + r[2, 1], 1 - r[0, 0] - r[1, 1] + r[2, 2]], -1),
    ], axis=1)                                              # (n, 4 candidates, 4)
    best = np.argmax(np.stack([trace, r[0, 0], r[1, 1], r[2, 2]], -1), axis=1)
    q = candidates[np.arange(m.shape[0]), best]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    return _canonical(q)


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
    a = _rows(e, (3,), "euler")
    rx, ry, rz = (_axis_rotations(a[:, i], i) for i in range(3))
    return rz @ ry @ rx if convention == "zyx" else rx @ ry @ rz


def euler_to_quaternion(e, convention="zyx"):
    """Unit quaternions ``(n, 4)``, canonical ``w >= 0``, of Euler angles ``(3,)`` or ``(n, 3)``
    in radians; ``convention`` as in :func:`euler_to_matrix`."""
    _check_convention(convention)
    half = 0.5 * _rows(e, (3,), "euler")
    zero = np.zeros_like(half[:, 0])
    c, s = np.cos(half), np.sin(half)
    qx = np.stack([c[:, 0], s[:, 0], zero, zero], -1)
    qy = np.stack([c[:, 1], zero, s[:, 1], zero], -1)
    qz = np.stack([c[:, 2], zero, zero, s[:, 2]], -1)
    if convention == "zyx":
        q = quaternion_multiply(quaternion_multiply(qz, qy), qx)
    else:
        q = quaternion_multiply(quaternion_multiply(qx, qy), qz)
    return _canonical(q)


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
    m = _rows(R, (3, 3), "matrix")
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


def quaternion_multiply(q1, q2):
    """Hamilton products ``q1 * q2`` (apply ``q2`` first, then ``q1``), shape (n, 4).

    ``q1``, ``q2``: quaternions ``[w, x, y, z]``, shape (4,) or (n, 4); rows broadcast.
    """
    a, b = np.broadcast_arrays(_rows(q1, (4,), "quaternion"), _rows(q2, (4,), "quaternion"))
    w1, x1, y1, z1 = np.moveaxis(a, 1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, 1, 0)
    return np.stack([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ], axis=-1)


def quaternion_conjugate(q):
    """Conjugates ``[w, -x, -y, -z]``, shape (n, 4): the inverse rotation of unit ``q``."""
    return _rows(q, (4,), "quaternion") * np.array([1.0, -1.0, -1.0, -1.0])


def random_quaternions(n, rng):
    """``n`` unit quaternions ``(n, 4)`` uniform on SO(3) (Shoemake's method).

    ``n``: number of rotations (>= 0); ``rng``: a ``numpy.random.Generator``.
    """
    u1, u2, u3 = rng.random((3, int(n)))
    a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
    t2, t3 = 2.0 * np.pi * u2, 2.0 * np.pi * u3
    return np.stack([b * np.cos(t3), a * np.sin(t2), a * np.cos(t2), b * np.sin(t3)], axis=-1)


def _reject_non_finite(a, field):
    bad = ~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
    if bad.any():
        raise InvalidRotationError(field, np.flatnonzero(bad), "non-finite value (NaN or Inf)")


def validate_quaternion(q):
    """Checked, normalised quaternions ``(n, 4)`` (sign kept as given).

    Raises :class:`InvalidRotationError` (field ``"quaternion"``) for a wrong shape, a
    non-finite value or a norm below :data:`QUATERNION_MIN_NORM`.
    """
    a = _rows(q, (4,), "quaternion")
    _reject_non_finite(a, "quaternion")
    norm = np.linalg.norm(a, axis=1)
    small = norm < QUATERNION_MIN_NORM
    if small.any():
        raise InvalidRotationError("quaternion", np.flatnonzero(small),
                                   f"norm below {QUATERNION_MIN_NORM:g} (no rotation)")
    return a / norm[:, None]


def validate_matrix(R):
    """Checked rotation matrices ``(n, 3, 3)``, re-orthonormalised to the nearest rotation.

    Raises :class:`InvalidRotationError` (field ``"matrix"``) for a wrong shape, a non-finite
    value, ``max |R^T R - I| > ROTATION_MATRIX_TOL`` (shear, scale) or ``det R < 0``
    (reflection). Accepted rows are replaced by ``U @ V^T`` of their SVD, the nearest rotation
    in the Frobenius norm.
    """
    m = _rows(R, (3, 3), "matrix")
    _reject_non_finite(m, "matrix")
    error = np.abs(np.swapaxes(m, 1, 2) @ m - np.eye(3)).max(axis=(1, 2))
    not_orthonormal = error > ROTATION_MATRIX_TOL
    if not_orthonormal.any():
        raise InvalidRotationError("matrix", np.flatnonzero(not_orthonormal),
                                   f"max |R^T R - I| above {ROTATION_MATRIX_TOL:g}")
    reflection = np.linalg.det(m) < 0
    if reflection.any():
        raise InvalidRotationError("matrix", np.flatnonzero(reflection),
                                   "determinant < 0 (a reflection, not a rotation)")
    u, _, vt = np.linalg.svd(m)
    return u @ vt


def validate_euler(e):
    """Checked Euler angles ``(n, 3)`` in radians (any finite value, e.g. pitch = +-pi/2).

    Raises :class:`InvalidRotationError` (field ``"euler"``) for a wrong shape or a non-finite
    value.
    """
    a = _rows(e, (3,), "euler")
    _reject_non_finite(a, "euler")
    return a


def _exactly_one(quaternion, matrix, euler):
    given = [name for name, v in (("quaternion", quaternion), ("matrix", matrix),
                                  ("euler", euler)) if v is not None]
    if len(given) != 1:
        raise InvalidRotationError(
            "orientation", [],
            f"exactly one of quaternion, matrix, euler must be given, got {given or 'none'}")
    return given[0]


def rotation_to_quaternion(quaternion=None, matrix=None, euler=None, euler_convention="zyx"):
    """Validated unit quaternions ``(n, 4)`` from exactly one orientation input.

    ``quaternion`` (4,) or (n, 4): normalised, sign kept; ``matrix`` (3, 3) or (n, 3, 3) and
    ``euler`` (3,) or (n, 3) radians in ``euler_convention``: canonical sign ``w >= 0``.
    Raises :class:`InvalidRotationError`, field ``"orientation"`` unless exactly one input is
    given, else as the ``validate_*`` functions.
    """
    kind = _exactly_one(quaternion, matrix, euler)
    if kind == "quaternion":
        return validate_quaternion(quaternion)
    if kind == "matrix":
        return matrix_to_quaternion(validate_matrix(matrix))
    return euler_to_quaternion(validate_euler(euler), euler_convention)


def rotation_to_matrix(quaternion=None, matrix=None, euler=None, euler_convention="zyx"):
    """Validated rotation matrices ``(n, 3, 3)`` from exactly one orientation input.

    Parameters and errors as :func:`rotation_to_quaternion`.
    """
    kind = _exactly_one(quaternion, matrix, euler)
    if kind == "quaternion":
        return quaternion_to_matrix(validate_quaternion(quaternion))
    if kind == "matrix":
        return validate_matrix(matrix)
    return euler_to_matrix(validate_euler(euler), euler_convention)
