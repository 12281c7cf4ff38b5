"""Batch columns -> the dispatcher's validated :class:`~impactnet.models.dispatch.Pairs`:
shapes, finiteness, ranges, names, rotations.

Everything is vectorised over pairs: columns become NumPy arrays in one call each, checks are
array expressions that report the offending rows, object names are looked up once per distinct
name, and raw sizes become one box shape per distinct size. The columns come from a JSON body
(:mod:`impactnet.service.codecs.batch_json`) or an npz body (:mod:`impactnet.service.codecs.npz`,
layout in docs/service.md); both read this module's column table first, to check a column's
size before it is decoded.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.dispatch import Pairs
from impactnet.models.dispatch.shapes import Shapes
from impactnet.models.geometry.rotations import InvalidRotationError, rotation_to_quaternion
from impactnet.service.codecs.pair import rotation_reason, unknown_object_reason
from impactnet.service.codecs.requests import (
    ANGLE_MAX,
    OBJECT_NAME_MAX,
    POSITION_MAX_M,
    SIZE_MAX_M,
    SIZE_MIN_M,
)
from impactnet.service.errors import InputError, PayloadTooLarge
from impactnet.service.scene import SceneView

JSON = "application/json"
NPZ = "application/x-npz"
OPTIONS = ("mode", "include", "euler_convention", "margin")
#: Per side: column -> (trailing shape, lower bound, upper bound); "object" holds names.
NUMERIC = {
    "size": ((3,), SIZE_MIN_M, SIZE_MAX_M),
    "position": ((3,), -POSITION_MAX_M, POSITION_MAX_M),
    "quaternion": ((4,), -ANGLE_MAX, ANGLE_MAX),
    "matrix": ((3, 3), -ANGLE_MAX, ANGLE_MAX),
    "euler": ((3,), -ANGLE_MAX, ANGLE_MAX),
}
COLUMNS = tuple(f"{side}_{name}" for side in "ab"
                for name in ("object", "size", "position", "quaternion", "matrix", "euler"))
#: Bytes a NumPy string holds per character (``<U``: UCS-4).
UNICODE_CHAR_BYTES = 4


def tail_of(column: str) -> tuple[int, ...] | None:
    """Trailing shape of one row of a numeric column, None for an object-name column."""
    kind = column.split("_", 1)[1]
    return None if kind == "object" else NUMERIC[kind][0]


def unknown_column(name: str) -> InputError:
    return InputError(str(name), f"unknown column; columns are {', '.join(COLUMNS)} and "
                      f"options {', '.join(OPTIONS)}", type_="extra_forbidden")


def too_many_pairs(n: int, max_pairs: int) -> PayloadTooLarge:
    return PayloadTooLarge("batch_too_large", f"{n} pairs in one batch; the limit is "
                           f"{max_pairs}")


def _rows_of(array: np.ndarray, tail: tuple) -> tuple[np.ndarray, bool]:
    """``(n, *tail)`` view and whether the column is per pair (else one broadcast value).
    An empty list (JSON ``[]``, shape (0,)) is a column of zero pairs."""
    if array.shape == tail:
        return array[None], False
    if array.ndim == len(tail) + 1 and array.shape[1:] == tail:
        return array, True
    if array.shape == (0,):
        return array.reshape((0, *tail)), True
    raise ValueError


def _numeric(name: str, value, tail: tuple, lo: float, hi: float):
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as exc:  # nested lists of unequal lengths
        raise InputError(name, "ragged: its rows do not all have the same length",
                         type_="ragged") from exc
    if array.dtype.kind not in "iuf":
        what = {"b": "booleans", "U": "strings", "S": "bytes"}.get(array.dtype.kind,
                                                                     "non-numbers or nulls")
        raise InputError(name, f"expected numbers, got {what}", type_="float_type")
    try:
        rows, per_pair = _rows_of(array, tail)
    except ValueError:
        want = f"{list(tail)} or [N, {', '.join(map(str, tail))}]"
        raise InputError(name, f"expected shape {want}, got {list(array.shape)}",
                         type_="shape") from None
    rows = rows.astype(np.float64, copy=False)
    flat = rows.reshape(len(rows), math.prod(tail))  # -1 is ambiguous for 0 rows
    bad = ~np.isfinite(flat).all(axis=1)
    if bad.any():
        raise InputError(name, "not a finite number (NaN or Infinity)", np.flatnonzero(bad),
                         type_="finite_number")
    bad = ((flat < lo) | (flat > hi)).any(axis=1)
    if bad.any():
        reason = (f"sizes must be > 0, within [{lo:g}, {hi:g}] m" if name.endswith("_size")
                  else f"outside [{lo:g}, {hi:g}]")
        raise InputError(name, reason, np.flatnonzero(bad), type_="out_of_range")
    return rows, per_pair


def _names(name: str, value):
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise InputError(name, "ragged", type_="ragged") from exc
    if array.shape == (0,):  # JSON [] (float64) or an empty <U column: zero pairs
        return np.zeros(0, dtype="<U1"), True
    if array.dtype.kind != "U" or array.ndim > 1:
        raise InputError(name, "expected an object name or an array of N names",
                         type_="string_type")
    if array.dtype.itemsize // 4 > OBJECT_NAME_MAX:
        raise InputError(name, f"names are at most {OBJECT_NAME_MAX} characters",
                         type_="string_too_long")
    return (array[None], False) if array.ndim == 0 else (array, True)


def _one_of(columns: dict, prefix: str, names: tuple[str, ...]) -> str:
    given = [n for n in names if f"{prefix}{n}" in columns]
    if len(given) != 1:
        choices = ", ".join(f"{prefix}{n}" for n in names)
        raise InputError(f"{prefix}{names[0]}", f"give exactly one of {choices} (got "
                         f"{', '.join(f'{prefix}{n}' for n in given) or 'none'})",
                         type_="missing" if not given else "conflict")
    return given[0]


def body_columns(columns: dict, prefix: str) -> tuple[dict, dict]:
    """The validated columns of one body per row (``prefix``: ``a_``, ``b_``, or empty for a
    frame's bodies): its shape (``object`` names or ``size``), ``position`` and one
    orientation. Returns (column -> rows, column -> whether it has one row per pair)."""
    if f"{prefix}position" not in columns:
        raise InputError(f"{prefix}position", "required column", type_="missing")
    size_kind = _one_of(columns, prefix, ("size", "object"))
    orientation = _one_of(columns, prefix, ("quaternion", "matrix", "euler"))
    parsed, per_pair = {}, {}
    for kind in (size_kind, "position", orientation):
        key = f"{prefix}{kind}"
        if kind == "object":
            parsed[key], per_pair[key] = _names(key, columns[key])
        else:
            parsed[key], per_pair[key] = _numeric(key, columns[key], *NUMERIC[kind])
    return parsed, per_pair


def row_count(parsed: dict, per_pair: dict, max_rows: int, request: str = "batch",
              too_many=too_many_pairs) -> int:
    """N of validated columns: every per-row column has the same length, 1 to ``max_rows``
    (422 for ragged or empty, 413 ``too_many(n, max_rows)`` past the cap); ``request``:
    ``batch`` (rows are pairs) or ``frame`` (rows are bodies)."""
    lengths = {k: len(v) for k, v in parsed.items() if per_pair[k]}
    n = max(lengths.values(), default=1)
    ragged = sorted(k for k, length in lengths.items() if length != n)
    if ragged:
        raise InputError(ragged[0], f"ragged {request}: columns have different lengths ("
                         + ", ".join(f"{k}: {v}" for k, v in sorted(lengths.items())) + ")",
                         type_="ragged")
    if n == 0:
        what = "pair" if request == "batch" else "body"
        raise InputError(next(iter(lengths)), f"empty {request}: give at least one {what}",
                         type_="too_short")
    if n > max_rows:
        raise too_many(n, max_rows)
    return n


def batch_pairs(columns: dict, scene: SceneView, convention: str,
                max_pairs: int) -> Pairs:
    """Validate the columns of a batch and broadcast them to N pairs.

    Raises InputError (422, naming the column and rows) and PayloadTooLarge (413, N above
    ``max_pairs``).
    """
    unknown = sorted(set(columns) - set(COLUMNS))
    if unknown:
        raise unknown_column(unknown[0])
    parsed, per_pair = {}, {}
    for side in "ab":
        values, rows = body_columns(columns, f"{side}_")
        parsed |= values
        per_pair |= rows
    n = row_count(parsed, per_pair, max_pairs)
    extra: list = []
    out = {}
    for side in "ab":
        out[f"shape_{side}"], out[f"position_{side}"], out[f"quaternion_{side}"] = \
            body_arrays(parsed, f"{side}_", n, scene, convention, extra)
    sizes = np.concatenate(extra) if extra else None
    return Pairs(Shapes(scene.shapes, sizes), **out)


def _unique_rows(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the distinct rows (k, 3) of ``values`` (n, 3), each row's index among them (n,)), by a
    sort of the columns (np.unique's ``axis=0`` sorts rows as opaque records, ~2x slower, with
    the GIL held: the event loop stalled 50 ms on 100,000 sizes)."""
    values = np.asarray(values, np.float64).reshape(-1, 3)
    order = np.lexsort(values.T[::-1])
    ordered = values[order]
    new = np.ones(len(values), bool)
    new[1:] = (ordered[1:] != ordered[:-1]).any(axis=1)
    inverse = np.empty(len(values), np.int64)
    inverse[order] = np.cumsum(new) - 1
    return ordered[new], inverse


def _shape_column(parsed: dict, prefix: str, n: int, scene: SceneView, extra: list):
    """(n,) shape indices of one body column: scene objects by name, raw sizes as boxes
    appended to ``extra`` (an array (k, 3) of the k distinct sizes: one shape each)."""
    if f"{prefix}object" in parsed:
        index, bad = scene.with_compound.lookup(parsed[f"{prefix}object"])
        if bad.size:
            names = np.unique(parsed[f"{prefix}object"][bad])
            raise InputError(f"{prefix}object", unknown_object_reason(names, scene), bad,
                             type_="unknown_object")
        return np.broadcast_to(index, (n,))
    sizes, inverse = _unique_rows(parsed[f"{prefix}size"])
    start = len(scene.shapes) + sum(len(e) for e in extra)
    extra.append(np.asarray(sizes, np.float64).reshape(-1, 3))
    return np.broadcast_to(start + inverse.reshape(-1), (n,))


def body_arrays(parsed: dict, prefix: str, n: int, scene: SceneView, convention: str,
                extra: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(shape indices (n,) into ``scene.shapes + extra``, positions (n, 3), unit quaternions
    (n, 4)) of one body column's validated rows (:func:`body_columns`); raw sizes append
    their box shapes to ``extra``."""
    shape = _shape_column(parsed, prefix, n, scene, extra)
    position = np.broadcast_to(parsed[f"{prefix}position"], (n, 3))
    kind = next(k for k in ("quaternion", "matrix", "euler") if f"{prefix}{k}" in parsed)
    try:
        q = rotation_to_quaternion(**{kind: parsed[f"{prefix}{kind}"]},
                                   euler_convention=convention)
    except InvalidRotationError as exc:
        raise InputError(f"{prefix}{kind}", rotation_reason(exc), exc.rows,
                         type_="invalid_rotation") from exc
    return shape, position, np.broadcast_to(q, (n, 4))
