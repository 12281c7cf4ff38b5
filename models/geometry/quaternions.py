"""Quaternions ``[w, x, y, z]`` (Hamilton, scalar first) and rotation matrices, vectorised over
n rows, float64: conversions both ways, products, conjugates and uniform random rotations
(conventions: :mod:`impactnet.models.geometry.rotations`)."""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.rotation_rows import as_rows, canonical_sign


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
    q = as_rows(q, (4,), "quaternion")
    if len(q) == 1:  # one row in Python floats: the same formula, ~20 NumPy calls fewer
        return np.array(quaternion_matrix(*q[0].tolist()), np.float64).reshape(1, 3, 3)
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
    m = as_rows(R, (3, 3), "matrix")
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
    return canonical_sign(q)


def quaternion_multiply(q1, q2):
    """Hamilton products ``q1 * q2`` (apply ``q2`` first, then ``q1``), shape (n, 4).

    ``q1``, ``q2``: quaternions ``[w, x, y, z]``, shape (4,) or (n, 4); rows broadcast.
    """
    a, b = np.broadcast_arrays(as_rows(q1, (4,), "quaternion"), as_rows(q2, (4,), "quaternion"))
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
    return as_rows(q, (4,), "quaternion") * np.array([1.0, -1.0, -1.0, -1.0])


def random_quaternions(n, rng):
    """``n`` unit quaternions ``(n, 4)`` uniform on SO(3) (Shoemake's method).

    ``n``: number of rotations (>= 0); ``rng``: a ``numpy.random.Generator``.
    """
    u1, u2, u3 = rng.random((3, int(n)))
    a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
    t2, t3 = 2.0 * np.pi * u2, 2.0 * np.pi * u3
    return np.stack([b * np.cos(t3), a * np.sin(t2), a * np.cos(t2), b * np.sin(t3)], axis=-1)
