"""Batch columns -> validated `PairInputs`: shapes, finiteness, ranges, names, rotations.

Everything is vectorised over pairs: columns become NumPy arrays in one call each, checks are
array expressions that report the offending rows, and object names are looked up once per
distinct name. The columns come from a JSON body (:mod:`impactnet.service.codecs.batch_json`) or an
npz body
(:mod:`impactnet.service.codecs.npz`, layout in docs/service.md); both read this module's column
table first,
to check a column's size before it is decoded.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.geometry.rotations import InvalidRotationError, rotation_to_quaternion
from impactnet.service.api.schemas import (
    ANGLE_MAX,
    OBJECT_NAME_MAX,
    POSITION_MAX_M,
    SIZE_MAX_M,
    SIZE_MIN_M,
)
from impactnet.service.codecs.pairs import rotation_reason, unknown_object_reason
from impactnet.service.errors import InputError, PayloadTooLarge
from impactnet.service.predictors import PairInputs
from impactnet.service.scene import SceneView

JSON = "application/json"
NPZ = "application/x-npz"
OPTIONS = ("mode", "include", "euler_convention")
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


def _one_of(columns: dict, side: str, names: tuple[str, ...]) -> str:
    given = [n for n in names if f"{side}_{n}" in columns]
    if len(given) != 1:
        choices = ", ".join(f"{side}_{n}" for n in names)
        raise InputError(f"{side}_{names[0]}", f"give exactly one of {choices} (got "
                         f"{', '.join(f'{side}_{n}' for n in given) or 'none'})",
                         type_="missing" if not given else "conflict")
    return given[0]


def batch_pairs(columns: dict, scene: SceneView, convention: str,
                max_pairs: int) -> PairInputs:
    """Validate the columns of a batch and broadcast them to N pairs.

    Raises InputError (422, naming the column and rows) and PayloadTooLarge (413, N above
    ``max_pairs``).
    """
    unknown = sorted(set(columns) - set(COLUMNS))
    if unknown:
        raise unknown_column(unknown[0])
    parsed, per_pair = {}, {}
    for side in "ab":
        if f"{side}_position" not in columns:
            raise InputError(f"{side}_position", "required column", type_="missing")
        size_kind = _one_of(columns, side, ("size", "object"))
        orientation = _one_of(columns, side, ("quaternion", "matrix", "euler"))
        for kind in (size_kind, "position", orientation):
            key = f"{side}_{kind}"
            if kind == "object":
                parsed[key], per_pair[key] = _names(key, columns[key])
            else:
                parsed[key], per_pair[key] = _numeric(key, columns[key], *NUMERIC[kind])
    lengths = {k: len(v) for k, v in parsed.items() if per_pair[k]}
    n = max(lengths.values(), default=1)
    ragged = sorted(k for k, length in lengths.items() if length != n)
    if ragged:
        raise InputError(ragged[0], "ragged batch: columns have different lengths (" + ", ".join(
            f"{k}: {v}" for k, v in sorted(lengths.items())) + ")", type_="ragged")
    if n == 0:
        raise InputError(next(iter(lengths)), "empty batch: give at least one pair",
                         type_="too_short")
    if n > max_pairs:
        raise too_many_pairs(n, max_pairs)
    out = {}
    for side in "ab":
        if f"{side}_object" in parsed:
            index, bad = scene.lookup(parsed[f"{side}_object"])
            if bad.size:
                names = np.unique(parsed[f"{side}_object"][bad])
                raise InputError(f"{side}_object", unknown_object_reason(names, scene), bad,
                                 type_="unknown_object")
            out[f"size_{side}"] = scene.sizes[index]
            out[f"object_{side}"] = index
        else:
            out[f"size_{side}"] = parsed[f"{side}_size"]
            out[f"object_{side}"] = np.full(1, -1)
        out[f"position_{side}"] = parsed[f"{side}_position"]
        kind = next(k for k in ("quaternion", "matrix", "euler") if f"{side}_{k}" in parsed)
        try:
            out[f"quaternion_{side}"] = rotation_to_quaternion(
                **{kind: parsed[f"{side}_{kind}"]}, euler_convention=convention)
        except InvalidRotationError as exc:
            raise InputError(f"{side}_{kind}", rotation_reason(exc), exc.rows,
                             type_="invalid_rotation") from exc
    width = {"size": 3, "position": 3, "quaternion": 4}
    return PairInputs(**{k: (np.broadcast_to(v, (n, width[k.split("_")[0]]))
                             if k.split("_")[0] in width else np.broadcast_to(v, (n,)))
                         for k, v in out.items()})
