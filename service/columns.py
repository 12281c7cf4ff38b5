"""Batches: columnar JSON or npz in, validated `PairInputs`; `Contacts` out as JSON or npz.

Everything is vectorised over pairs: columns become NumPy arrays in one call each, checks are
array expressions that report the offending rows, object names are looked up once per distinct
name, and the JSON answer is written by orjson straight from the arrays.

Binary layout (``application/x-npz``, request and response): an uncompressed or deflated
NumPy ``.npz`` archive, read with ``allow_pickle=False``; one ``.npy`` member per column, named
like the JSON columns. Numbers as any integer or float dtype (converted to float64), names as
unicode (``<U``) arrays. See docs/service.md for the full layout.
"""
from __future__ import annotations

import io
import math
import zipfile

import numpy as np
import orjson

from models.contacts import CONTACT_TYPES, Contacts
from models.rotations import InvalidRotationError, rotation_to_quaternion
from service.errors import InputError, PayloadTooLarge
from service.pairs import paper_angles, rotation_reason, unknown_object_reason
from service.predictors import PairInputs
from service.scene import SceneView
from service.schemas import ANGLE_MAX, OBJECT_NAME_MAX, POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M

JSON = "application/json"
NPZ = "application/x-npz"
OPTIONS = ("mode", "include", "euler_convention")
#: Per side: column -> (trailing shape, lower bound, upper bound); "object" holds names.
_NUMERIC = {
    "size": ((3,), SIZE_MIN_M, SIZE_MAX_M),
    "position": ((3,), -POSITION_MAX_M, POSITION_MAX_M),
    "quaternion": ((4,), -ANGLE_MAX, ANGLE_MAX),
    "matrix": ((3, 3), -ANGLE_MAX, ANGLE_MAX),
    "euler": ((3,), -ANGLE_MAX, ANGLE_MAX),
}
COLUMNS = tuple(f"{side}_{name}" for side in "ab"
                for name in ("object", "size", "position", "quaternion", "matrix", "euler"))
_CONTACT_NAMES = np.asarray(CONTACT_TYPES)
_NPY_HEADER_MAX = 10_000  # bytes; np.save writes ~128


# ------------------------------------------------------------------------------ decoding


def parse_json(body: bytes) -> tuple[dict, dict]:
    """``(columns, options)`` of a JSON batch body."""
    try:
        data = orjson.loads(body)
    except orjson.JSONDecodeError as exc:
        raise InputError("body", f"malformed JSON: {exc}", type_="json_invalid") from exc
    if not isinstance(data, dict):
        raise InputError("body", "expected a JSON object of columns", type_="json_type")
    options = {k: data.pop(k) for k in OPTIONS if k in data}
    return data, options


def parse_npz(body: bytes, max_bytes: int) -> dict:
    """Columns of an npz body. Headers are read first: object arrays, members larger than
    their data and a total expanded size above ``max_bytes`` (413) are refused unread."""
    try:
        archive = zipfile.ZipFile(io.BytesIO(body))
        members = archive.infolist()
        if sum(m.file_size for m in members) > max_bytes:
            raise PayloadTooLarge("body_too_large", f"npz body expands beyond the limit of "
                                  f"{max_bytes} bytes")
        columns = {}
        for member in members:
            name = member.filename
            if not name.endswith(".npy") or name[:-4] in columns:
                raise InputError("body", f"npz member {name!r}: expected one <column>.npy per "
                                 "column", type_="npz_invalid")
            with archive.open(member) as f:
                version = np.lib.format.read_magic(f)
                if version not in ((1, 0), (2, 0)):
                    raise ValueError(f"npy format version {version} (use 1.0 or 2.0)")
                read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                        else np.lib.format.read_array_header_2_0)
                shape, _, dtype = read(f, max_header_size=_NPY_HEADER_MAX)
                if dtype.hasobject:
                    raise InputError(name[:-4], "object arrays are not accepted (no pickle)",
                                     type_="npz_invalid")
                if math.prod(shape) * dtype.itemsize > member.file_size:
                    raise ValueError(f"member {name!r} is shorter than its header says")
            with archive.open(member) as f:
                columns[name[:-4]] = np.lib.format.read_array(
                    f, allow_pickle=False, max_header_size=_NPY_HEADER_MAX)
        return columns
    except (InputError, PayloadTooLarge):
        raise
    except Exception as exc:  # noqa: BLE001 - any fault of untrusted bytes is a bad body
        raise InputError("body", f"malformed npz: {type(exc).__name__}: {exc}",
                         type_="npz_invalid") from exc


def _rows_of(array: np.ndarray, tail: tuple) -> tuple[np.ndarray, bool]:
    """``(n, *tail)`` view and whether the column is per pair (else one broadcast value)."""
    if array.shape == tail:
        return array[None], False
    if array.ndim == len(tail) + 1 and array.shape[1:] == tail:
        return array, True
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
    flat = rows.reshape(len(rows), -1)
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
        raise InputError(str(unknown[0]), f"unknown column; columns are {', '.join(COLUMNS)} "
                         f"and options {', '.join(OPTIONS)}", type_="extra_forbidden")
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
                parsed[key], per_pair[key] = _numeric(key, columns[key], *_NUMERIC[kind])
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
        raise PayloadTooLarge("batch_too_large", f"{n} pairs in one batch; the limit is "
                              f"{max_pairs}")
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


# ------------------------------------------------------------------------------ encoding


def answer_arrays(contacts: Contacts, pairs: PairInputs, include) -> dict[str, np.ndarray]:
    """The answer's columns as arrays (little-endian, C-contiguous)."""
    first = contacts.predictor[:1]
    if len(first) and (contacts.predictor == first[0]).all():  # one predictor: skip the sort
        predictor_names, predictor_code = first, np.zeros(len(contacts), np.int8)
    else:
        predictor_names, predictor_code = np.unique(contacts.predictor, return_inverse=True)
    out = {
        "colliding": contacts.colliding.astype(np.bool_),
        "point": contacts.point.astype("<f8"),
        "normal": contacts.normal.astype("<f8"),
        "depth": contacts.depth.astype("<f8"),
        "contact_type_code": contacts.contact_type_code.astype(np.int8),
        "feature_a": contacts.feature_a.astype(np.int8),
        "feature_b": contacts.feature_b.astype(np.int8),
        "axis": contacts.axis.astype(np.int8),
        "confidence": contacts.confidence.astype("<f8"),
        "predictor_code": predictor_code.reshape(-1).astype(np.int8),
        "predictor_names": predictor_names.astype(str),
    }
    if "manifold" in include:
        out["manifold_count"] = contacts.manifold_count.astype(np.int8)
        out["manifold_points"] = contacts.manifold_points.astype("<f8")
        out["manifold_depths"] = contacts.manifold_depths.astype("<f8")
    if "paper_angles" in include:
        out["paper_angles"] = paper_angles(contacts, pairs).astype("<f8")
    return {k: np.ascontiguousarray(v) for k, v in out.items()}


def encode_json(arrays: dict, mode: str, model_version: str) -> bytes:
    body = {"n": int(len(arrays["depth"])), "mode": mode, "model_version": model_version,
            "predictor": arrays["predictor_names"][arrays["predictor_code"]].tolist(),
            "contact_type": _CONTACT_NAMES[arrays["contact_type_code"]].tolist()}
    skip = ("predictor_code", "predictor_names", "contact_type_code")
    body.update((k, v) for k, v in arrays.items() if k not in skip)
    return orjson.dumps(body, option=orjson.OPT_SERIALIZE_NUMPY)


def encode_npz(arrays: dict, mode: str, model_version: str) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, mode=np.array(mode), model_version=np.array(model_version),
             contact_type_names=_CONTACT_NAMES, **arrays)
    return buffer.getvalue()
