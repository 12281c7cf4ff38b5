"""The exact box-box contact solver: oracle, fallback and yardstick of impactnet.

Public entries:

* :func:`box_box`: exact contacts of N box pairs (one pair or a batch), a new `Contacts`;
* :func:`box_box_into`: the same into preallocated arrays (:func:`empty_contacts`), for a
  simulator that asks every step;
* :func:`prepare_inputs`: the six inputs validated, broadcast and normalised as the solver
  uses them.

The solver itself is compiled (:mod:`impactnet.models.box.kernels`, whose stage modules
document every stage, tolerance and tie rule): stage 0 checks the inputs in the kernel, stages
1-4 solve each pair in A's local frame (the separating-axis test with its tie rule, the face
manifold, the centre of pressure) and map the answer back to the world frame. This module only
shapes the inputs into float64 rows and turns a fault the kernel reports into the named error.

One pair as six float64 vectors (the way a simulator calls) goes straight to the one-pair
kernel (:func:`impactnet.models.box.kernels.one_pair_entry`). Anything else is shaped into
(k, w) rows (k = 1 broadcasts, k = n): fewer than ``PARALLEL_MIN_ROWS`` pairs are checked and
solved in one serial call, more are checked, then solved over the kernel threads in chunks of
``CHUNK_ROWS`` with a work-limit checkpoint between chunks
(:mod:`impactnet.models.compiled`). Every path runs the same row function, so a pair gets the
same answer to the last bit alone or in a batch of any size.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box import kernel_inputs as ki
from impactnet.models.box import kernels
from impactnet.models.box.kernel_views import unit_rows
from impactnet.models.compiled import PARALLEL_MIN_ROWS, chunks, launch
from impactnet.models.contacts import MAX_MANIFOLD_POINTS, Contacts
from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry.rotations import QUATERNION_MIN_NORM, InvalidRotationError

_ND = np.ndarray
_F64, _BOOL, _INT8 = np.dtype(np.float64), np.dtype(np.bool_), np.dtype(np.int8)
_NAMES = tuple(name for name, _, _ in kernels.OUTPUTS)
_EXACT = np.array(["exact"])
_ONES = np.ones(1)
_ONE, _ONE_3, _ONE_M3, _ONE_M = (1,), (1, 3), (1, MAX_MANIFOLD_POINTS, 3), (1,
                                                                          MAX_MANIFOLD_POINTS)
_empty, _new = np.empty, object.__new__
#: The message of each fault kind (:mod:`impactnet.models.box.kernel_inputs`).
_REASONS = {
    ki.NOT_FINITE: "not finite",
    ki.SIZE_NOT_POSITIVE: "sizes must be > 0",
    ki.SIZE_OUT_OF_DOMAIN: f"sizes must be in [{SIZE_MIN_M:g}, {SIZE_MAX_M:g}] m",
    ki.POSITION_OUT_OF_DOMAIN: f"|coordinates| must be <= {POSITION_MAX_M:g} m",
    ki.QUATERNION_NORM: f"norm below {QUATERNION_MIN_NORM:g} (no rotation)",
}


class InvalidBoxError(ValueError):
    """A box input is not usable; ``field`` names it and ``rows`` the offending pairs."""

    def __init__(self, field: str, rows, reason: str):
        self.field, self.rows = field, np.asarray(rows).tolist()
        super().__init__(f"{field}: {reason} (rows {self.rows[:10]})")


def _contacts(out: list, n: int) -> Contacts:
    """A `Contacts` around the output arrays, with confidence 1 and predictor "exact"."""
    contacts = Contacts.__new__(Contacts)
    fields = dict(zip(_NAMES, out))
    fields["confidence"], fields["predictor"] = np.ones(n), np.full(n, "exact")
    contacts.__dict__.update(fields)
    return contacts


def empty_contacts(n: int) -> Contacts:
    """A `Contacts` of n rows for :func:`box_box_into` (solver fields uninitialised,
    confidence 1, predictor "exact")."""
    return _contacts(kernels.output_arrays(n), n)


def fault_error(fault: int, rows, n: int) -> ValueError:
    """The named error of a kernel fault, with every offending row."""
    code, _ = divmod(fault, 1 << ki.ROW_BITS)
    kind, field = divmod(code, 8)
    name = ki.FIELDS[field]
    mask = np.empty(len(rows[field]) if kind == ki.NOT_FINITE else n, np.bool_)
    ki.fault_rows(rows[field], kind, n, mask)
    if kind == ki.QUATERNION_NORM:
        return InvalidRotationError("quaternion", np.flatnonzero(mask), _REASONS[kind])
    return InvalidBoxError(name, np.flatnonzero(mask), _REASONS[kind])


def _rows_of(value, width: int) -> np.ndarray | None:
    """An input as C-contiguous, writable float64 (k, w) rows; None for a wrong shape."""
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0 or array.ndim > 2 or array.shape[-1] != width:
        return None
    array = array.reshape(-1, width)
    flags = array.flags
    return array if flags.c_contiguous and flags.writeable else np.array(array, order="C")


def checked_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """The six inputs as (k, w) float64 rows (k 1 or n) and n, checked by the kernel.

    Raises
    ------
    InvalidBoxError, impactnet.models.geometry.rotations.InvalidRotationError
        The first fault in :mod:`impactnet.models.box.kernel_inputs`' order, with every
        offending row.
    """
    rows = []
    for value, width, name in zip((size_a, position_a, quaternion_a, size_b, position_b,
                                   quaternion_b), ki.WIDTHS, ki.FIELDS):
        array = _rows_of(value, width)
        if array is None:
            _raise_not_finite(rows)
            shape = np.shape(np.asarray(value, dtype=np.float64))
            raise InvalidBoxError(name, [], f"expected shape ({width},) or (n, {width}), got "
                                  f"{shape}")
        rows.append(array)
    lengths = {len(r) for r in rows} - {1}
    if len(lengths) > 1:
        _raise_not_finite(rows)
        raise InvalidBoxError("pairs", [], f"inputs do not broadcast: row counts "
                              f"{sorted(lengths)}")
    n = lengths.pop() if lengths else 1
    return rows, n


def _raise_not_finite(rows) -> None:
    """Raise the not-finite error of the first of ``rows`` holding a non-finite row."""
    for field, array in enumerate(rows):
        fault = ki.finite_fault(array, field)
        if fault:
            raise fault_error(fault, rows, len(array))


def prepare_inputs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """Validate and broadcast the six inputs to n rows each, quaternions normalised as the
    solver normalises them.

    Returns
    -------
    tuple of ndarray
        ``size_a (n, 3), position_a (n, 3), quaternion_a (n, 4), size_b, position_b,
        quaternion_b``, float64 (one-row inputs as read-only broadcast views).
    """
    rows, n = checked_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    fault = ki.first_fault(*rows, n)
    if fault:
        raise fault_error(fault, rows, n)
    for k in (2, 5):
        unit = np.empty_like(rows[k])
        unit_rows(rows[k], unit)
        rows[k] = unit
    return tuple(r if len(r) == n else np.broadcast_to(r, (n, r.shape[1])) for r in rows)


def _solve(rows, n: int, out: list) -> None:
    """Check and solve n pairs of shaped rows into the output arrays (module docstring)."""
    if n < PARALLEL_MIN_ROWS:
        fault = kernels.solve_checked(*rows, *out, n)
    else:
        fault = ki.first_fault(*rows, n)
    if fault:
        raise fault_error(fault, rows, n)
    if n >= PARALLEL_MIN_ROWS:
        for start, stop in chunks(n):
            if stop - start >= PARALLEL_MIN_ROWS:
                launch(kernels.solve_rows_parallel, *rows, *out, start, stop)
            else:
                kernels.solve_rows(*rows, *out, start, stop)


def box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b) -> Contacts:
    """Exact contact of N box pairs.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,) or (n, 3)
        Full edge lengths (metres), in [1e-6, 1e6] (:mod:`impactnet.models.domain`).
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Box centres in the world frame (metres), |coordinates| <= 1e9.
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Orientations (w, x, y, z); normalised here, norm < 1e-6 is an error.

    Returns
    -------
    Contacts
        N rows; see :class:`impactnet.models.contacts.Contacts`.

    Raises
    ------
    InvalidBoxError, impactnet.models.geometry.rotations.InvalidRotationError
        Non-finite input, size <= 0 or outside the domain, degenerate quaternion or
        non-broadcasting shapes; the error names the field and the rows.
    """
    if type(size_a) is not _ND and type(size_a) in _SEQUENCES:  # one pair as lists
        size_a, position_a, quaternion_a, size_b, position_b, quaternion_b = _vectors(
            size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    if type(size_a) is _ND and size_a.ndim == 1:  # one pair, as a simulator asks: the
        # output arrays one by one and the answer's dictionary at once (fewest NumPy calls)
        e = _empty
        colliding, normal, depth, point, code, feature_a, feature_b, axis, points, depths, \
            count, pressure = out = (
                e(_ONE, _BOOL), e(_ONE_3, _F64), e(_ONE, _F64), e(_ONE_3, _F64), e(_ONE, _INT8),
                e(_ONE, _INT8), e(_ONE, _INT8), e(_ONE, _INT8), e(_ONE_M3, _F64),
                e(_ONE_M, _F64), e(_ONE, _INT8), e(_ONE, _F64))
        try:
            fault = (_solve_one or _one_pair())(size_a, position_a, quaternion_a, size_b,
                                                position_b, quaternion_b, *out)
        except TypeError:  # not six float64 vectors: shaped below
            fault = -1
        if fault == 0:
            contacts = _new(Contacts)
            contacts.__dict__ = {
                "colliding": colliding, "normal": normal, "depth": depth, "point": point,
                "contact_type_code": code, "feature_a": feature_a, "feature_b": feature_b,
                "axis": axis, "manifold_points": points, "manifold_depths": depths,
                "manifold_count": count, "confidence": _ONES.copy(),
                "predictor": _EXACT.copy(), "pressure": pressure}
            return contacts
    rows, n = checked_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    out = kernels.output_arrays(n)
    _solve(rows, n, out)
    return _contacts(out, n)


_SEQUENCES, _NUMBERS = (list, tuple), (float, int)
#: The one-pair kernel once closed (:func:`impactnet.models.box.kernels.one_pair_entry`).
_solve_one = None


def _one_pair():
    global _solve_one
    _solve_one = kernels.one_pair_entry()
    return _solve_one


def _vectors(*values) -> tuple:
    """The six inputs, as float64 vectors where the first is a sequence of 3 numbers (one pair
    as lists); as given where they are not, or where that fails (the batch path then shapes
    them and raises the precise error)."""
    if len(values[0]) == 3 and type(values[0][0]) in _NUMBERS:
        try:
            return tuple(np.array(v, _F64) for v in values)
        except (TypeError, ValueError):
            pass
    return values


def box_box_into(out: Contacts, size_a, position_a, quaternion_a, size_b, position_b,
                 quaternion_b) -> Contacts:
    """:func:`box_box` into the arrays of ``out`` (n rows, e.g. from :func:`empty_contacts` or
    an earlier answer), without allocating; returns ``out``.

    Only the solver's fields are written (``confidence`` and ``predictor`` are left as they
    are); every array of those fields must be C-contiguous and writable, with the shape and
    dtype :func:`box_box` gives, for as many rows as the inputs broadcast to. On an input
    error nothing is written.

    Raises
    ------
    InvalidBoxError, InvalidRotationError
        As :func:`box_box` (first); ``ValueError`` for output arrays that do not fit.
    """
    arrays = [getattr(out, name) for name in _NAMES]
    if type(size_a) is not _ND and type(size_a) in _SEQUENCES:  # one pair as lists
        size_a, position_a, quaternion_a, size_b, position_b, quaternion_b = _vectors(
            size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    if type(size_a) is _ND and size_a.ndim == 1:
        try:
            fault = (_solve_one or _one_pair())(size_a, position_a, quaternion_a, size_b,
                                                position_b, quaternion_b, *arrays)
        except TypeError:  # inputs or outputs of another type: checked below
            fault = -1
        if fault == 0:
            return out
    rows, n = checked_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    fault = ki.first_fault(*rows, n)  # input errors first, as box_box raises them
    if fault:
        raise fault_error(fault, rows, n)
    for (name, shape, dtype), array in zip(kernels.OUTPUTS, arrays):
        if not (type(array) is _ND and array.shape == (n, *shape) and array.dtype == dtype
                and array.flags.c_contiguous and array.flags.writeable):
            raise ValueError(f"out.{name}: expected a writable C-contiguous {np.dtype(dtype)} "
                             f"array of shape {(n, *shape)}")
    _solve(rows, n, arrays)
    return out
