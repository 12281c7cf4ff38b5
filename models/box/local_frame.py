"""Stage 1 of the vectorised exact solver (see :mod:`impactnet.models.box.exact`): a block of pairs
in A's
local frame, as columns.

The vectorised solver (:mod:`impactnet.models.box.exact`) works on *columns*: every quantity of a
block of m
pairs is one contiguous float64 array of shape (m,), and the formulas over the 3 components
or the 9 matrix entries are written out term by term. NumPy's elementwise kernels are fast on
long contiguous arrays, while matmul / einsum over (m, 3, 3) stacks with their inner dimension
of 3 are slow; written out, each formula also evaluates its terms in exactly the order of the
plain-Python path (:mod:`impactnet.models.box.exact_one`), so that both paths round identically.

Layout. :class:`LocalPose` keeps the relative pose of a block in one (22, m) array; matrices
are row-major in their 9 rows (entry (i, j) at row ``3 i + j``).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.rotations import quaternion_matrix

#: Rows of the input block built by :func:`input_columns`, in the order of the solver's
#: arguments: size_a, position_a, quaternion_a, size_b, position_b, quaternion_b.
INPUT_SLICES = (slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13), slice(13, 16),
                slice(16, 20))
INPUT_ROWS = 20


def input_columns(inputs, start: int, stop: int) -> np.ndarray:
    """Rows ``start:stop`` of the six (n, 3|4) inputs as one (20, m) column block."""
    block = np.empty((INPUT_ROWS, stop - start))
    for rows, value in zip(INPUT_SLICES, inputs):
        block[rows] = value[start:stop].T
    return block


def matvec(matrix: np.ndarray, v) -> np.ndarray:
    """``matrix @ v`` on stacked columns, (9, ...) row-major and (3, ...) -> (3, ...), each
    entry summed in index order (``m[i, 0] v[0] + m[i, 1] v[1] + m[i, 2] v[2]``)."""
    m = matrix.reshape(3, 3, *matrix.shape[1:])
    return m[:, 0] * v[0] + m[:, 1] * v[1] + m[:, 2] * v[2]


def b_to_a(pose, rows: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (3, k) given in B's frame of the pairs ``rows`` (k,) of ``pose`` (a
    :class:`LocalPose`), in A's frame: ``t + R p``."""
    in_b = np.take(pose.data[6:18], rows, axis=1)  # R (9 rows), t (3)
    return in_b[9:] + matvec(in_b[:9], points)


def matvec_transposed(matrix, v, out) -> None:
    """``out = matrix.T @ v``, i.e. ``sum_i matrix[i] * v[i]`` in index order.

    ``matrix`` is (3, 3, m) (row i at ``matrix[i]``) and ``v`` (3, m); the items may also
    broadcast, e.g. a (3, m) column of matrices times (3, 3, m) rows.
    """
    np.multiply(matrix[0], v[0], out=out)
    out += matrix[1] * v[1]
    out += matrix[2] * v[2]


class AxisChoice:
    """A per-row choice of one of 3 axes, ``index`` (m,) in 0-2, applied to stacked columns."""

    def __init__(self, index: np.ndarray):
        self.is0, self.is1 = index == 0, index == 1

    def pick(self, stacked):
        """``stacked[index]`` per row: (3, ..., m) -> (..., m)."""
        return np.where(self.is0, stacked[0], np.where(self.is1, stacked[1], stacked[2]))


class LocalPose:
    """Relative pose of m pairs in A's frame, as columns of one (22, m) float64 array.

    Attributes (views into ``data``)
    --------------------------------
    ha, hb : ndarray, shape (3, m)
        Half-extents of A and B (metres).
    r : ndarray, shape (9, m)
        ``R = R_A^T R_B``, row-major: B's axes are the columns, in A's frame.
    t : ndarray, shape (3, m)
        B's centre in A's frame, ``R_A^T (p_B - p_A)`` (metres).
    tb : ndarray, shape (3, m)
        ``R^T t``: the same offset in B's frame (metres).
    scale : ndarray, shape (m,)
        Pair scale, the sum of both largest half-extents (metres), for the tolerances.
    """

    ROWS = 22

    def __init__(self, data: np.ndarray):
        self.data = data
        self.ha, self.hb, self.r = data[0:3], data[3:6], data[6:15]
        self.t, self.tb, self.scale = data[15:18], data[18:21], data[21]

    def take(self, rows: np.ndarray) -> LocalPose:
        """The pose of the pairs ``rows`` (indices into the block), as a new block."""
        return LocalPose(np.take(self.data, rows, axis=1))


def local_pose(block: np.ndarray) -> tuple[LocalPose, np.ndarray]:
    """The pairs of an input block (see :func:`input_columns`) in A's frame.

    Returns
    -------
    pose : LocalPose
    rot_a : ndarray, shape (9, m)
        A's rotation matrix (row-major), for mapping results back to the world frame.
    """
    data = np.empty((LocalPose.ROWS, block.shape[1]))
    pose = LocalPose(data)
    np.multiply(block[INPUT_SLICES[0]], 0.5, out=pose.ha)
    np.multiply(block[INPUT_SLICES[3]], 0.5, out=pose.hb)
    rot_a = np.array(quaternion_matrix(*block[INPUT_SLICES[2]]))
    rot_b = np.array(quaternion_matrix(*block[INPUT_SLICES[5]]))
    for i in range(3):  # row i of R_A^T R_B: column i of R_A (3, m) times the rows of R_B
        matvec_transposed(rot_a[i::3], rot_b.reshape(3, 3, -1), pose.r[3 * i:3 * i + 3])
    offset = block[INPUT_SLICES[4]] - block[INPUT_SLICES[1]]
    matvec_transposed(rot_a.reshape(3, 3, -1), offset, pose.t)
    matvec_transposed(pose.r.reshape(3, 3, -1), pose.t, pose.tb)
    ha, hb = pose.ha, pose.hb
    np.add(np.maximum(np.maximum(ha[0], ha[1]), ha[2]),
           np.maximum(np.maximum(hb[0], hb[1]), hb[2]), out=pose.scale)
    return pose, rot_a

