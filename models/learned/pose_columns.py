"""Column-wise canonical features and their inverse, for the learned predictors' batches.

The same stages as :mod:`impactnet.models.learned.canonical` (relative pose, canonical signs,
``pose-v1``
features; ``contact-v1`` outputs back to the world), written for speed as columns: a block of m
rows is a set of contiguous (m,) columns, and every
formula is written out term by term (NumPy is fast on long contiguous arrays, slow on
(m, 3, 3) stacks). Differences to the reference functions, all at rounding level (tested):

* quaternions are not normalised up front: their squared norms, taken once at validation,
  scale the matrix formulas (``s = 2 / |q|^2``);
* ``R = R_A^T R_B`` is built from the relative quaternion ``conj(q_A) q_B`` instead of the
  product of two matrices;
* the signs with ties to +1 come from ``copysign(1, x + 0.0)`` (``-0.0 + 0.0`` is ``+0.0``).

Inputs arrive as :class:`Inputs`, whose arrays keep one row where the caller passed one
(e.g. the pair's sizes), so that nothing is broadcast to N rows that need not be.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models.box.exact import prepare_inputs
from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry.rotations import QUATERNION_MIN_NORM
from impactnet.models.learned.canonical import FALLBACK_NORMAL, NORMAL_NORM_MIN

#: Rows per block of the column-wise stages: a block's live float32 columns (16384 rows:
#: 64 kB each) stay near the CPU's L2 cache while each of its ~80 NumPy calls covers many rows
#: (measured on one core: 4096 rows 30 % slower, 32768 no faster).
ROW_BLOCK = 16384
#: Smallest accepted squared quaternion norm of the fast check; a hair above the exact
#: solver's limit so that a norm at the limit goes to
#: :func:`impactnet.models.box.exact.prepare_inputs`,
#: which decides it (and raises its precise error).
_NORM2_MIN = (QUATERNION_MIN_NORM * (1.0 + 1e-9)) ** 2
#: Widths of the six inputs, in box_box's order.
WIDTHS = (3, 3, 4, 3, 3, 4)


class Inputs(NamedTuple):
    """Validated inputs of n pairs, float64; every array has 1 row (broadcast) or n rows."""

    size_a: np.ndarray  # (1|n, 3) full edge lengths, metres
    position_a: np.ndarray  # (1|n, 3) metres, world frame
    quaternion_a: np.ndarray  # (1|n, 4) (w, x, y, z), not normalised
    size_b: np.ndarray
    position_b: np.ndarray
    quaternion_b: np.ndarray
    norm2_a: np.ndarray  # (1|n,) squared norms of quaternion_a
    norm2_b: np.ndarray  # (1|n,) squared norms of quaternion_b
    n: int  # number of pairs

    def take(self, rows: np.ndarray) -> Inputs:
        """The pairs ``rows`` (integer indices) as new Inputs."""
        picked = [a if len(a) == 1 else np.take(a, rows, axis=0) for a in self[:8]]
        return Inputs(*picked, len(rows))

    def swapped(self) -> Inputs:
        """The same pairs with A and B exchanged."""
        return Inputs(*self[3:6], *self[0:3], self.norm2_b, self.norm2_a, self.n)

    def full(self) -> tuple[np.ndarray, ...]:
        """The six arrays broadcast to n rows (read-only views where broadcast)."""
        return tuple(np.broadcast_to(a, (self.n, a.shape[1])) for a in self[:6])


def checked_inputs(size_a, position_a, quaternion_a, size_b, position_b,
                   quaternion_b) -> Inputs:
    """Validate the six inputs as :func:`impactnet.models.box.exact.prepare_inputs` does.

    A few whole-array reductions accept valid input; anything else goes through
    ``prepare_inputs``, which raises the precise error (or accepts, then its normalised
    arrays are used).
    """
    values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    rows = []
    for value, width in zip(values, WIDTHS):
        array = np.asarray(value, dtype=np.float64)
        if array.ndim not in (1, 2) or array.shape[-1] != width or array.size == 0:
            return _slow_inputs(values)
        rows.append(array.reshape(-1, width))
    lengths = {len(r) for r in rows} - {1}
    if len(lengths) > 1:
        return _slow_inputs(values)
    for k in (0, 3):
        if not (rows[k].min() >= SIZE_MIN_M and rows[k].max() <= SIZE_MAX_M):
            return _slow_inputs(values)
    for k in (1, 4):
        if not (rows[k].min() >= -POSITION_MAX_M and rows[k].max() <= POSITION_MAX_M):
            return _slow_inputs(values)
    norms = [np.einsum("ij,ij->i", rows[k], rows[k]) for k in (2, 5)]
    if not all(v.min() >= _NORM2_MIN and v.max() < np.inf for v in norms):
        return _slow_inputs(values)
    return Inputs(*rows, *norms, lengths.pop() if lengths else 1)


def _slow_inputs(values) -> Inputs:
    rows = prepare_inputs(*values)
    n = len(rows[0])
    return Inputs(*rows, np.ones(n), np.ones(n), n)


def _block(array: np.ndarray, start: int, stop: int, dtype) -> np.ndarray:
    """Rows ``start:stop`` of an (1|n, w) array as a contiguous (w, m) block of columns (a
    one-row array is repeated)."""
    rows = array if len(array) == 1 else array[start:stop]
    block = np.empty((array.shape[1], stop - start), dtype)
    block[...] = rows.T
    return block


def block_rows(array: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Rows ``start:stop`` of an (1|n, ...) array (a one-row array as it is, to broadcast)."""
    return array if len(array) == 1 else array[start:stop]


def _rotation(q: np.ndarray, s, out: np.ndarray) -> np.ndarray:
    """Row-major rotation entries (9, m) of quaternions q (4, m) (w, x, y, z) into ``out``;
    ``s = 2 / |q|^2`` (m,)."""
    v = q[1:] * s  # x s, y s, z s
    w = q[0] * v  # wx, wy, wz
    x = q[1] * v  # xx, xy, xz
    yy, yz, zz = q[2] * v[1], q[2] * v[2], q[3] * v[2]
    np.subtract(1.0, yy + zz, out=out[0])
    np.subtract(x[1], w[2], out=out[1])
    np.add(x[2], w[1], out=out[2])
    np.add(x[1], w[2], out=out[3])
    np.subtract(1.0, x[0] + zz, out=out[4])
    np.subtract(yz, w[0], out=out[5])
    np.subtract(x[2], w[1], out=out[6])
    np.add(yz, w[0], out=out[7])
    np.subtract(1.0, x[0] + yy, out=out[8])
    return out


def _relative_quaternion(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """``conj(q_A) q_B`` (4, m) (Hamilton product), the quaternion of ``R_A^T R_B``."""
    p = (qa[:, None] * qb[None]).reshape(16, -1)  # p[4 i + j] = qa_i qb_j
    q = np.empty_like(qa)
    np.add(p[0], p[5], out=q[0])
    q[0] += p[10]
    q[0] += p[15]
    np.subtract(p[1:4], p[4:13:4], out=q[1:])  # aw b_v - bw a_v
    q[1:] -= p[[11, 13, 6]]  # - a_v x b_v: (ay bz, az bx, ax by) ...
    q[1:] += p[[14, 7, 9]]  # ... - (az by, ax bz, ay bx)
    return q


def _matvec_transposed(m3: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``M^T v`` (3, m) of row-major matrices m3 (3, 3, m) and vectors v (3, m)."""
    out = m3[0] * v[0]
    out += m3[1] * v[1]
    out += m3[2] * v[2]
    return out


class Frame(NamedTuple):
    """What maps a block's canonical answers back to the world (m rows)."""

    to_world: np.ndarray  # (9, m) float32, R_A S row-major: canonical A frame -> world axes
    flip_a: np.ndarray  # (m,) int8, index of S among the sign flips (0-7)
    flip_b: np.ndarray  # (m,) int8, index of T


#: Weights of the signs in a sign-flip index: ``3.5 - w . s = 4 (s0<0) + 2 (s1<0) + (s2<0)``.
_FLIP_WEIGHTS = np.array([2.0, 1.0, 0.5], np.float32)


def _flip_index(signs: np.ndarray) -> np.ndarray:
    """Index (m,) int8 of diag(signs) among the sign flips, signs (3, m) in {-1, 1}."""
    return np.subtract(3.5, _FLIP_WEIGHTS @ signs).astype(np.int8)


def canonical_block(inputs: Inputs, start: int, stop: int, inv_scale: float,
                    features: np.ndarray) -> Frame:
    """``pose-v1`` features of rows ``start:stop`` into ``features`` (m, 12) float32.

    ``inv_scale`` is ``1 / L`` of the pair (1/metres); returns the block's :class:`Frame`.
    The world offset ``p_B - p_A`` is taken in float64, the rotation algebra after it in
    float32 (features within 1e-6 of :mod:`impactnet.models.learned.canonical`'s, tested).
    """
    m = stop - start
    qa = _block(inputs.quaternion_a, start, stop, np.float32)
    qb = _block(inputs.quaternion_b, start, stop, np.float32)
    norm2_a = block_rows(inputs.norm2_a, start, stop)
    norm2_b = block_rows(inputs.norm2_b, start, stop)
    scale_a = (2.0 / norm2_a).astype(np.float32)
    scale_ab = (2.0 / (norm2_a * norm2_b)).astype(np.float32)
    offset = (block_rows(inputs.position_b, start, stop)
              - block_rows(inputs.position_a, start, stop))
    offset = _block(offset, 0, m, np.float32)  # p_B - p_A in float64, then float32 columns
    rot_a = _rotation(qa, scale_a, np.empty((9, m), np.float32)).reshape(3, 3, m)
    rot = _rotation(_relative_quaternion(qa, qb), scale_ab, np.empty((9, m), np.float32))
    t = _matvec_transposed(rot_a, offset)  # R_A^T (p_B - p_A)
    s = np.copysign(np.float32(1.0), t + np.float32(0.0))  # ties (0, -0) give +1
    # T = sign(u), u = -R^T t: A's centre in B's frame; ties give +1.
    sign_b = np.copysign(np.float32(1.0),
                         np.float32(0.0) - _matvec_transposed(rot.reshape(3, 3, m), t))
    np.multiply(np.abs(t), inv_scale, out=features[:, :3].T)
    np.multiply(rot, (s[:, None] * sign_b[None]).reshape(9, m), out=features[:, 3:].T)
    to_world = (rot_a * s[None]).reshape(9, m)  # (R_A S)_ij = R_A,ij s_j
    return Frame(to_world, _flip_index(s), _flip_index(sign_b))


def world_block(columns: np.ndarray, frame: Frame, origin: np.ndarray, scale: float,
                point: np.ndarray, normal: np.ndarray) -> None:
    """World point and normal of canonical ``contact-v1`` outputs, into ``point``, ``normal``.

    Parameters
    ----------
    columns : ndarray, shape (>= 6, m), float32
        A block's outputs as columns: point / L (3), normal (3); normals shorter than
        NORMAL_NORM_MIN are replaced by FALLBACK_NORMAL in place.
    frame : Frame
        From :func:`canonical_block` for the same rows.
    origin : ndarray, shape (1 | m, 3), float64
        What the canonical point is relative to, world frame (metres): A's position
        (``block_rows(inputs.position_a, start, stop)``), or the committee's unclipped
        points (its experts predict the residual).
    scale : float
        The pair's L, metres.
    point, normal : ndarray, shape (m, 3), float64
        Outputs (metres, world frame; unit vectors).
    """
    n = columns[3:6]
    norm2 = np.einsum("im,im->m", n, n)
    short = norm2 < NORMAL_NORM_MIN ** 2
    if short.any():
        n[:, short] = FALLBACK_NORMAL[:, None]
        norm2[short] = 1.0
    rows = frame.to_world.reshape(3, 3, -1)  # rows[r, j]: entry (r, j) of R_A S
    world_n = rows[:, 0] * n[0]
    world_n += rows[:, 1] * n[1]
    world_n += rows[:, 2] * n[2]
    np.multiply(world_n, 1.0 / np.sqrt(norm2), out=normal.T)
    p = columns[:3]
    world_p = rows[:, 0] * p[0]
    world_p += rows[:, 1] * p[1]
    world_p += rows[:, 2] * p[2]
    world_p *= np.float32(scale)
    np.add(origin, world_p.T, out=point)
