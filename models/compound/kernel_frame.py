"""Stage 0 of the compiled compound pipeline: one pose's frames, rounded as the NumPy oracle
rounded them (scalar row functions, :func:`impactnet.models.compiled.jit`).

The NumPy oracle's answers (``tests/data/golden``) start from NumPy's own sums, so every
product of a matrix and a vector here names the order NumPy summed it in:

* ``np.einsum`` over C-contiguous rows sums ``(r0 x0 + r2 x2) + r1 x1`` (:func:`pair_rows`),
  over a transposed view in order, ``r0 x0 + r1 x1 + r2 x2`` (:func:`plain_columns`);
* ``np.matmul`` hands 3x3 stacks to OpenBLAS, whose kernels fuse multiply-adds:
  ``fma(a2, b2, fma(a1, b1, a0 b0))`` for a matrix product, a transposed matrix times a vector
  and a vector times a matrix (:func:`fused`), but ``fma(a2, b2, fma(a0, b0, a1 b1))`` for a
  C-contiguous matrix times a vector (OpenBLAS's ``gemv_t``, :func:`fused_gemv`); measured on
  every product the broadphase and the filter take (``tests/models/compound``).

Layout: vectors are 3-tuples, matrices 9-tuples in row-major order (as
:mod:`impactnet.models.box.kernel_frame`). numba compiles without fast-math, so nothing else is
fused or reassociated.
"""
from __future__ import annotations

import math

from llvmlite import ir

from impactnet.models.box.kernel_frame import rotation_of
from impactnet.models.compiled import jit, numba
from impactnet.models.geometry.rotations import QUATERNION_MIN_NORM


@numba.extending.intrinsic
def fma(typingctx, a, b, c):
    """``a b + c`` rounded once (LLVM's ``llvm.fma.f64``: the CPU's instruction, or libm's
    correctly rounded ``fma``): OpenBLAS's multiply-add."""
    signature = numba.types.float64(numba.types.float64, numba.types.float64,
                                    numba.types.float64)

    def codegen(context, builder, sig, args):
        double = ir.DoubleType()
        fn = numba.core.cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(double, [double, double, double]), "llvm.fma.f64")
        return builder.call(fn, args)

    return signature, codegen


@jit
def fused(a0, a1, a2, b0, b1, b2):
    """``a . b`` as OpenBLAS's ``gemm`` and ``gemv_n`` sum it: ``fma(a2, b2, fma(a1, b1,
    a0 b0))``."""
    return fma(a2, b2, fma(a1, b1, a0 * b0))


@jit
def fused_gemv(a0, a1, a2, b0, b1, b2):
    """``a . b`` as OpenBLAS's ``gemv_t`` sums it (a C-contiguous matrix's row ``a`` times a
    vector ``b``): ``fma(a2, b2, fma(a0, b0, a1 b1))``."""
    return fma(a2, b2, fma(a0, b0, a1 * b1))


@jit
def pair_rows(m, x0, x1, x2):
    """``M x`` (3-tuple) as ``np.einsum("kij,kj->ki")`` sums C-contiguous rows:
    ``(m0 x0 + m2 x2) + m1 x1``."""
    return ((m[0] * x0 + m[2] * x2) + m[1] * x1, (m[3] * x0 + m[5] * x2) + m[4] * x1,
            (m[6] * x0 + m[8] * x2) + m[7] * x1)


@jit
def plain_columns(m, x0, x1, x2):
    """``M^T x`` (3-tuple) summed in order, as ``np.einsum`` sums a transposed view (and
    ``"kji,kj->ki"``): ``m0 x0 + m3 x1 + m6 x2``."""
    return (m[0] * x0 + m[3] * x1 + m[6] * x2, m[1] * x0 + m[4] * x1 + m[7] * x2,
            m[2] * x0 + m[5] * x1 + m[8] * x2)


@jit
def fused_product(a, b):
    """``A^T B`` (9-tuple) as ``np.matmul`` of a transposed stack and a stack rounds it
    (:func:`fused` per entry)."""
    return (fused(a[0], a[3], a[6], b[0], b[3], b[6]), fused(a[0], a[3], a[6], b[1], b[4], b[7]),
            fused(a[0], a[3], a[6], b[2], b[5], b[8]),
            fused(a[1], a[4], a[7], b[0], b[3], b[6]), fused(a[1], a[4], a[7], b[1], b[4], b[7]),
            fused(a[1], a[4], a[7], b[2], b[5], b[8]),
            fused(a[2], a[5], a[8], b[0], b[3], b[6]), fused(a[2], a[5], a[8], b[1], b[4], b[7]),
            fused(a[2], a[5], a[8], b[2], b[5], b[8]))


@jit
def pick(rows, i):
    """The row of an input of 1 or n rows that pose i reads."""
    return i if rows.shape[0] > 1 else 0


@jit
def unit(rows, i):
    """Row i (broadcast) of (k, 4) quaternions divided by its norm (``validate_quaternion``:
    the squares summed in order), as ``(w, x, y, z)``."""
    r = pick(rows, i)
    w, x, y, z = rows[r, 0], rows[r, 1], rows[r, 2], rows[r, 3]
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    return w / norm, x / norm, y / norm, z / norm


@jit
def bad_quaternions(quaternions_a, quaternions_b):
    """Whether a row of either (k, 4) array fails :func:`bad_quaternion` (one call for a
    pose's two bodies)."""
    return bad_quaternion(quaternions_a) or bad_quaternion(quaternions_b)


@jit
def bad_quaternion(quaternions):
    """Whether a row of (k, 4) quaternions is not finite or of a norm below
    :data:`~impactnet.models.geometry.rotations.QUATERNION_MIN_NORM` (the Python entry then
    raises :func:`~impactnet.models.geometry.rotations.validate_quaternion`'s error; positions
    are not checked, as the NumPy oracle did not: a NaN position culls every part pair)."""
    for r in range(quaternions.shape[0]):
        w, x, y, z = quaternions[r, 0], quaternions[r, 1], quaternions[r, 2], quaternions[r, 3]
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        finite = math.isfinite(w) and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)
        if not (finite and norm >= QUATERNION_MIN_NORM):
            return True
    return False


@jit
def pose_frame(position_a, quaternion_a, position_b, quaternion_b, i):
    """Pose i of the inputs (rows broadcast): ``(p_A, R_A, R_A', offset, p_B, R_B, R_B')``.

    ``R`` is the rotation of the quaternion normalised once (NumPy's ``quaternion_to_matrix``
    of ``validate_quaternion``: the broadphase, the convex solver and the filter use it);
    ``R'`` of the quaternion normalised twice (the box solver normalises its input again);
    ``offset = p_B - p_A`` (metres). Vectors are 3-tuples, rotations row-major 9-tuples.
    """
    ra, pa = pick(position_a, i), pick(position_b, i)
    p_a = (position_a[ra, 0], position_a[ra, 1], position_a[ra, 2])
    p_b = (position_b[pa, 0], position_b[pa, 1], position_b[pa, 2])
    qa, qb = unit(quaternion_a, i), unit(quaternion_b, i)
    qa2 = _renormalised(qa)
    qb2 = _renormalised(qb)
    return (p_a, rotation_of(qa[0], qa[1], qa[2], qa[3]),
            rotation_of(qa2[0], qa2[1], qa2[2], qa2[3]),
            (p_b[0] - p_a[0], p_b[1] - p_a[1], p_b[2] - p_a[2]), p_b,
            rotation_of(qb[0], qb[1], qb[2], qb[3]), rotation_of(qb2[0], qb2[1], qb2[2], qb2[3]))


@jit
def _renormalised(q):
    """A unit quaternion divided by its norm again (the box solver's own normalisation)."""
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm
