"""Stage 1 of the exact box-box solver: one pair in A's local frame, and the maps back.

Box A is centred at the origin with identity orientation; box B has rotation
``R = R_A^T R_B`` (B's axes as the columns of R) and centre ``t = R_A^T (p_B - p_A)``, so a pose
1e6 m from the origin gives the same answer as at it.

Layout (every function here is a scalar row function, :func:`impactnet.models.compiled.jit`):
vectors are 3-tuples of float64, matrices 9-tuples in row-major order (entry (i, j) at
``3 i + j``). Every sum is written out term by term, left to right, in the order the answers
were recorded in (``tests/data/golden``): ``m[3 r] v[0] + m[3 r + 1] v[1] + m[3 r + 2] v[2]``
for ``M v`` and ``m[c] v[0] + m[3 + c] v[1] + m[6 + c] v[2]`` for ``M^T v``. numba compiles
without fast-math, so no sum is reassociated or fused into a multiply-add.
"""
from __future__ import annotations

from impactnet.models.compiled import jit
from impactnet.models.geometry.rotations import quaternion_matrix

#: The rotation (9-tuple, row-major, dimensionless) of a unit quaternion ``(w, x, y, z)``:
#: impactnet's one quaternion-to-matrix formula, compiled as it is written.
rotation_of = jit(quaternion_matrix)


@jit
def maximum(a, b):
    """NumPy's ``maximum`` of two floats (the first where they are equal; NaN wins)."""
    return a if (a >= b or a != a) else b


@jit
def minimum(a, b):
    """NumPy's ``minimum`` of two floats (the first where they are equal; NaN wins)."""
    return a if (a <= b or a != a) else b


@jit
def sign(x):
    """The sign of ``x`` with ties at zero resolved to +1 (deterministic axis orientation)."""
    return 1.0 if x >= 0.0 else -1.0


@jit
def matvec(m, v):
    """``M v`` (3-tuple) of a row-major 9-tuple ``m`` and a 3-tuple ``v``."""
    return (m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
            m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2])


@jit
def matvec_transposed(m, v):
    """``M^T v`` (3-tuple) of a row-major 9-tuple ``m`` and a 3-tuple ``v``."""
    return (m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
            m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
            m[2] * v[0] + m[5] * v[1] + m[8] * v[2])


@jit
def transposed(m):
    """The transpose of a row-major 9-tuple."""
    return (m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8])


@jit
def moved(origin, m, v):
    """``origin + M v`` (3-tuple): a point of a frame with axes ``m`` (row-major 9-tuple, the
    frame's axes as columns) and origin ``origin``, in the enclosing frame (metres)."""
    mv = matvec(m, v)
    return (origin[0] + mv[0], origin[1] + mv[1], origin[2] + mv[2])


@jit
def local_frame(size_a, position_a, rot_a, size_b, position_b, rot_b):
    """A validated pair in A's frame (stage 1).

    Parameters
    ----------
    size_a, size_b : 3-tuple of float
        Full edge lengths (metres).
    position_a, position_b : 3-tuple of float
        Centres in the world frame (metres).
    rot_a, rot_b : 9-tuple of float
        Rotations (row-major, ``v_world = R v_body``).

    Returns
    -------
    ha, hb : 3-tuple
        Half-extents of A and B (metres).
    r : 9-tuple
        ``R = R_A^T R_B``, row-major: B's axes are the columns, in A's frame.
    t : 3-tuple
        B's centre in A's frame, ``R_A^T (p_B - p_A)`` (metres).
    tb : 3-tuple
        ``R^T t``: the same offset in B's frame (metres).
    scale : float
        The pair scale, the sum of both largest half-extents (metres), for the tolerances.
    """
    ha = (size_a[0] * 0.5, size_a[1] * 0.5, size_a[2] * 0.5)
    hb = (size_b[0] * 0.5, size_b[1] * 0.5, size_b[2] * 0.5)
    a, b = rot_a, rot_b
    # Row i of R_A^T R_B: column i of R_A times the rows of R_B.
    r = (a[0] * b[0] + a[3] * b[3] + a[6] * b[6], a[0] * b[1] + a[3] * b[4] + a[6] * b[7],
         a[0] * b[2] + a[3] * b[5] + a[6] * b[8],
         a[1] * b[0] + a[4] * b[3] + a[7] * b[6], a[1] * b[1] + a[4] * b[4] + a[7] * b[7],
         a[1] * b[2] + a[4] * b[5] + a[7] * b[8],
         a[2] * b[0] + a[5] * b[3] + a[8] * b[6], a[2] * b[1] + a[5] * b[4] + a[8] * b[7],
         a[2] * b[2] + a[5] * b[5] + a[8] * b[8])
    offset = (position_b[0] - position_a[0], position_b[1] - position_a[1],
              position_b[2] - position_a[2])
    t = matvec_transposed(a, offset)
    tb = matvec_transposed(r, t)
    scale = (maximum(maximum(ha[0], ha[1]), ha[2])
             + maximum(maximum(hb[0], hb[1]), hb[2]))
    return ha, hb, r, t, tb, scale


@jit
def to_world(position_a, rot_a, p):
    """A point ``p`` (3-tuple) of A's frame in the world frame: ``p_A + R_A p`` (metres)."""
    return moved(position_a, rot_a, p)
