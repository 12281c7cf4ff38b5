"""Checked orientation inputs: validated quaternions, rotation matrices and Euler angles, and
the conversion of exactly one of them to quaternions or matrices; every check raises
:class:`~impactnet.models.geometry.rotation_rows.InvalidRotationError` naming the bad rows."""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.euler import euler_to_matrix, euler_to_quaternion
from impactnet.models.geometry.quaternions import matrix_to_quaternion, quaternion_to_matrix
from impactnet.models.geometry.rotation_rows import InvalidRotationError, as_rows

#: Smallest accepted quaternion norm (dimensionless). Below it the quaternion is a zero
#: placeholder or the result of cancellation: normalising would amplify noise by > 1e6.
QUATERNION_MIN_NORM = 1e-6
#: Largest accepted max |R^T R - I| of an input matrix (dimensionless). Loose enough for
#: matrices stored in float32 (eps 6e-8) or printed with ~7 digits, tight enough to reject
#: any real shear or scale; accepted matrices are re-orthonormalised.
ROTATION_MATRIX_TOL = 1e-6


def _reject_non_finite(a, field):
    bad = ~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)
    if bad.any():
        raise InvalidRotationError(field, np.flatnonzero(bad), "non-finite value (NaN or Inf)")


def validate_quaternion(q):
    """Checked, normalised quaternions ``(n, 4)`` (sign kept as given).

    Raises :class:`InvalidRotationError` (field ``"quaternion"``) for a wrong shape, a
    non-finite value or a norm below :data:`QUATERNION_MIN_NORM`.
    """
    a = as_rows(q, (4,), "quaternion")
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
    m = as_rows(R, (3, 3), "matrix")
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
    a = as_rows(e, (3,), "euler")
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
