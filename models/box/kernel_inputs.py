"""Stage 0 of the exact box-box solver: the input checks, inside the kernel.

The six inputs arrive as float64 arrays of shape (k, w) (or (w,) for one pair), w = 3, 3, 4, 3,
3, 4 and k = 1 (broadcast over the pairs) or n. :func:`first_fault` checks them in the order
the errors have always been raised in, and returns the first fault found, encoded in one
integer (:func:`fault_code`); 0 when every pair is usable. The Python wrapper
(:mod:`impactnet.models.box.exact`) turns a fault into the named error, with every offending
row (:func:`fault_rows`).

Order of the checks (the first that fails is reported):

1. per input, in argument order: its width (:data:`SHAPE`, one-pair arrays only: the wrapper
   checks the shapes of batches), then every row finite (:data:`NOT_FINITE`, the rows of the
   input itself, before broadcasting);
2. the row counts broadcast (the wrapper's check);
3. sizes of A > 0 (:data:`SIZE_NOT_POSITIVE`), within the domain (:data:`SIZE_OUT_OF_DOMAIN`),
   then the same for B; positions of A, then of B, within the domain
   (:data:`POSITION_OUT_OF_DOMAIN`); quaternions of A, then of B, of norm at least
   :data:`impactnet.models.geometry.rotations.QUATERNION_MIN_NORM` (:data:`QUATERNION_NORM`).
   These rows are counted after broadcasting (a one-row input that fails fails every pair).
"""
from __future__ import annotations

import math

from impactnet.models.compiled import jit, numba
from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry.rotations import QUATERNION_MIN_NORM

#: Fault kinds (the high bits of a fault code).
SHAPE, NOT_FINITE, SIZE_NOT_POSITIVE, SIZE_OUT_OF_DOMAIN, POSITION_OUT_OF_DOMAIN, \
    QUATERNION_NORM = range(1, 7)
#: Inputs, in the solver's argument order (a fault names one by its index).
FIELDS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
#: Input widths, in the same order.
WIDTHS = (3, 3, 4, 3, 3, 4)
#: Bits of a fault code below the kind and the field: the row.
ROW_BITS = 40


def as_rows(array):
    """An input as (k, w) rows: a (w,) array as one row, a (k, w) array as it is (a view)."""
    return array


@numba.extending.overload(as_rows)
def _as_rows(array):
    if array.ndim == 1:
        return lambda array: array[None, :]
    return lambda array: array


@jit
def fault_code(kind, field, row):
    """One integer for a fault: its kind, the input (0-5) and the row (0 when none applies)."""
    return ((kind * 8 + field) << ROW_BITS) + row


@jit
def pick(rows, i):
    """The row of ``rows`` (k, w) that pair i reads: i, or 0 for a broadcast input."""
    return i if rows.shape[0] > 1 else 0


@jit
def vector(rows, i):
    """Row i (broadcast) of a (k, 3) input as a 3-tuple."""
    r = pick(rows, i)
    return (rows[r, 0], rows[r, 1], rows[r, 2])


@jit
def unit_quaternion(rows, i):
    """Row i (broadcast) of a (k, 4) input divided by its norm, as ``(w, x, y, z)``; the norm
    sums the squares in component order."""
    r = pick(rows, i)
    w, x, y, z = rows[r, 0], rows[r, 1], rows[r, 2], rows[r, 3]
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    return w / norm, x / norm, y / norm, z / norm


@jit
def row_fails(rows, kind, i):
    """Whether pair i (broadcast row) of one input fails the check ``kind`` (>= 2)."""
    r = pick(rows, i) if kind != NOT_FINITE else i
    bad = False
    for c in range(rows.shape[1]):
        v = rows[r, c]
        if kind == NOT_FINITE:
            bad |= not math.isfinite(v)
        elif kind == SIZE_NOT_POSITIVE:
            bad |= not v > 0.0
        elif kind == SIZE_OUT_OF_DOMAIN:
            bad |= not (v >= SIZE_MIN_M and v <= SIZE_MAX_M)
        elif kind == POSITION_OUT_OF_DOMAIN:
            bad |= not abs(v) <= POSITION_MAX_M
    if kind == QUATERNION_NORM:
        w, x, y, z = rows[r, 0], rows[r, 1], rows[r, 2], rows[r, 3]
        bad = not math.sqrt(w * w + x * x + y * y + z * z) >= QUATERNION_MIN_NORM
    return bad


@jit
def _first_row(rows, kind, field, n):
    """The fault of the first of ``n`` rows failing ``kind``, else 0."""
    for i in range(n):
        if row_fails(rows, kind, i):
            return fault_code(kind, field, i)
    return 0


@jit
def finite_fault(rows, field):
    """:data:`NOT_FINITE` of the first non-finite row of one input (its own rows), else 0."""
    return _first_row(rows, NOT_FINITE, field, rows.shape[0])


@jit
def _sizes_ok(rows, i):
    """Row i (broadcast) of a (k, 3) size input within the domain (so finite and > 0)."""
    s = vector(rows, i)
    return (s[0] >= SIZE_MIN_M and s[0] <= SIZE_MAX_M and s[1] >= SIZE_MIN_M
            and s[1] <= SIZE_MAX_M and s[2] >= SIZE_MIN_M and s[2] <= SIZE_MAX_M)


@jit
def _position_ok(rows, i):
    """Row i (broadcast) of a (k, 3) position input within the domain (so finite)."""
    p = vector(rows, i)
    return abs(p[0]) <= POSITION_MAX_M and abs(p[1]) <= POSITION_MAX_M and abs(
        p[2]) <= POSITION_MAX_M


@jit
def _quaternion_ok(rows, i):
    """Row i (broadcast) of a (k, 4) quaternion input finite, of norm at least the minimum."""
    r = pick(rows, i)
    w, x, y, z = rows[r, 0], rows[r, 1], rows[r, 2], rows[r, 3]
    finite = math.isfinite(w) and math.isfinite(x) and math.isfinite(y) and math.isfinite(z)
    return finite and math.sqrt(w * w + x * x + y * y + z * z) >= QUATERNION_MIN_NORM


@jit
def _usable(sa, pa, qa, sb, pb, qb, n):
    """Whether all ``n`` pairs pass every check (one straight pass, the common case)."""
    for i in range(n):
        if not (_sizes_ok(sa, i) and _sizes_ok(sb, i) and _position_ok(pa, i)
                and _position_ok(pb, i) and _quaternion_ok(qa, i) and _quaternion_ok(qb, i)):
            return False
    return True


@jit
def _ordered_fault(inputs, n):
    """The first fault of the six (k, w) inputs in the order of the module docstring."""
    for field in range(6):
        rows = inputs[field]
        if rows.shape[1] != (4 if field % 3 == 2 else 3):
            return fault_code(SHAPE, field, 0)
        fault = finite_fault(rows, field)
        if fault:
            return fault
    for kind, field in ((SIZE_NOT_POSITIVE, 0), (SIZE_OUT_OF_DOMAIN, 0),
                        (SIZE_NOT_POSITIVE, 3), (SIZE_OUT_OF_DOMAIN, 3),
                        (POSITION_OUT_OF_DOMAIN, 1), (POSITION_OUT_OF_DOMAIN, 4),
                        (QUATERNION_NORM, 2), (QUATERNION_NORM, 5)):
        fault = _first_row(inputs[field], kind, field, n)
        if fault:
            return fault
    return 0


@jit
def first_fault(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, n):
    """The first fault of the six inputs (module docstring), else 0.

    Parameters
    ----------
    size_a, position_a, quaternion_a, size_b, position_b, quaternion_b : ndarray
        float64, (k, w) with k 1 or ``n``; or (w,) each (one pair): then the widths are
        checked here too.
    n : int
        Number of pairs.

    Returns
    -------
    int
        0, or :func:`fault_code` of the first fault.
    """
    sa, pa, qa = as_rows(size_a), as_rows(position_a), as_rows(quaternion_a)
    sb, pb, qb = as_rows(size_b), as_rows(position_b), as_rows(quaternion_b)
    widths = (sa.shape[1] == 3 and pa.shape[1] == 3 and qa.shape[1] == 4 and sb.shape[1] == 3
              and pb.shape[1] == 3 and qb.shape[1] == 4)
    if widths and n > 0 and _usable(sa, pa, qa, sb, pb, qb, n):
        return 0
    return _ordered_fault((sa, pa, qa, sb, pb, qb), n)


@jit
def fault_rows(rows, kind, n, out):
    """Mark in ``out`` (bool, n or k rows) every row of one input that fails ``kind`` (the
    input's own rows for :data:`NOT_FINITE`, the n pairs otherwise)."""
    for i in range(out.shape[0]):
        out[i] = row_fails(rows, kind, i)
