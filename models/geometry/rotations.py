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
  (at gimbal lock ``a`` is set to 0). The paper (docs/design.md, "References") never names
  its Euler convention; its protocol draws each angle uniform in [-pi/2, pi/2]. impactnet uses
  ``"zyx"`` for it and offers ``"xyz"`` as the alternative reading.

Inputs broadcast: a single ``(4,)`` quaternion, ``(3,)`` Euler triple or ``(3, 3)`` matrix is a
batch of one; outputs always carry the leading ``n`` axis. The plain conversions assume valid
input (finite, unit quaternions, proper rotations); the ``validate_*`` and ``rotation_to_*``
functions check it and raise :class:`InvalidRotationError`.

The functions live in modules of one job each and are all importable from here:
:mod:`~impactnet.models.geometry.rotation_rows` (the error, input shaping),
:mod:`~impactnet.models.geometry.quaternions` (quaternions and matrices),
:mod:`~impactnet.models.geometry.euler` (Euler angles) and
:mod:`~impactnet.models.geometry.rotation_checks` (validation, one input of three).
"""
from __future__ import annotations

from impactnet.models.geometry.euler import (
    EULER_CONVENTIONS,
    GIMBAL_LOCK_TOL,
    euler_to_matrix,
    euler_to_quaternion,
    matrix_to_euler,
)
from impactnet.models.geometry.quaternions import (
    matrix_to_quaternion,
    quaternion_conjugate,
    quaternion_matrix,
    quaternion_multiply,
    quaternion_to_matrix,
    random_quaternions,
)
from impactnet.models.geometry.rotation_checks import (
    QUATERNION_MIN_NORM,
    ROTATION_MATRIX_TOL,
    rotation_to_matrix,
    rotation_to_quaternion,
    validate_euler,
    validate_matrix,
    validate_quaternion,
)
from impactnet.models.geometry.rotation_rows import InvalidRotationError

__all__ = ["EULER_CONVENTIONS", "GIMBAL_LOCK_TOL", "QUATERNION_MIN_NORM", "ROTATION_MATRIX_TOL",
           "InvalidRotationError", "euler_to_matrix", "euler_to_quaternion", "matrix_to_euler",
           "matrix_to_quaternion", "quaternion_conjugate", "quaternion_matrix",
           "quaternion_multiply", "quaternion_to_matrix", "random_quaternions",
           "rotation_to_matrix", "rotation_to_quaternion", "validate_euler", "validate_matrix",
           "validate_quaternion"]
