"""The one answer (:class:`~impactnet.models.dispatch.Answers`) as the API writes it: a single
pair's JSON object, a batch's columnar JSON or npz, streamed a slice of rows at a time.

A batch's columns, in order (the single pair's answer has the same keys, one value each, and
its ``contacts`` as a list of objects):

* per pair (``n``): ``colliding``, ``point``, ``normal``, ``depth``, ``distance`` (``-depth``
  in contact; the gap within the margin; null beyond it), ``closest_a`` and ``closest_b``
  (the closest points on A and on B, the centroids of the closest regions, for a pair apart
  by less than the margin; null otherwise), ``contact_type``, ``feature_a`` and
  ``feature_b`` (``{part, id, name, kind}`` of the deepest part contact), ``predictor``,
  ``confidence``, ``cluster_size``, and with ``include=paper_angles`` ``paper_angles`` (4 per
  pair, null without contact);
* ``contacts``: ``offsets`` (n + 1: pair i's at ``offsets[i]:offsets[i+1]``, the deepest
  first), ``part_a``, ``part_b``, ``point``, ``normal``, ``depth``, ``contact_type``,
  ``feature_a`` and ``feature_b`` (``{id, name, kind}``), ``axis`` (a box pair's separating
  axis, -1 for a convex part), ``pressure``, and with ``include=manifold`` ``manifold_count``,
  ``manifold_points`` (8 x 3 each), ``manifold_depths`` (8).

npz members are the same columns named by their path, a contact's with ``contact_`` first
(``feature_a_name``, ``contact_offsets``, ``contact_contact_type``, ``contact_feature_b_kind``),
plus ``n``, ``mode`` and ``model_version``; infinite distances stay infinite, missing angles
NaN, missing names empty. A single pair's contact carries its manifold as ``manifold``:
``{count, points, depths}`` (the valid points only).
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import chain
from math import isfinite

import numpy as np
import orjson

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.dispatch import Answers, Pairs
from impactnet.models.dispatch.answers import CONTACT_NAMES
from impactnet.service.codecs import features as ft
from impactnet.service.codecs.angles import paper_angles
from impactnet.service.codecs.stream import json_pieces, npz_pieces

#: Rows of one column per encoding step (~0.3-1 MB of JSON text at most).
STREAM_ROWS = 2048
#: Width of the npz string members: feature names, kinds, contact types, predictors.
NAME_DTYPE, KIND_DTYPE, TYPE_DTYPE, PREDICTOR_DTYPE = "<U24", "<U6", "<U11", "<U10"


@dataclass(frozen=True)
class Column:
    """One column: its path in the JSON object, its rows, how to read a slice of them."""

    path: tuple[str, ...]
    rows: int
    read: object  # (start, stop) -> ndarray (numbers) or object array (text, None)
    dtype: str  # the npz member's dtype
    shape: tuple = ()  # a row's shape


def _names(table: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """Names of codes (-1: None) as an object array."""
    out = np.full(len(codes), None, dtype=object)
    known = codes >= 0
    out[known] = table[codes[known]]
    return out


def _feature_columns(a: Answers, prefix: tuple, parts, ids, rows, body: bool,
                     label: ft.Labeller) -> list:
    last: dict = {}  # the labels of the last slice read: names and kinds labelled once

    def labelled(start, stop):
        if last.get("slice") != (start, stop):
            last["slice"] = (start, stop)
            last["labels"] = ft.labels(label, parts[start:stop], ids[start:stop])
        return last["labels"]

    def names(start, stop):
        return labelled(start, stop)[0]

    def kinds(start, stop):
        return labelled(start, stop)[1]

    out = [Column((*prefix, "part"), rows, lambda s, e: _names(a.part_names, parts[s:e]),
                  f"<U{max(1, max(map(len, a.part_names.tolist()), default=1))}")] if body else []
    return out + [Column((*prefix, "id"), rows, lambda s, e: ids[s:e], "<i4"),
                  Column((*prefix, "name"), rows, names, NAME_DTYPE),
                  Column((*prefix, "kind"), rows, kinds, KIND_DTYPE)]


def columns(a: Answers, pairs: Pairs, include) -> list[Column]:
    """Every column of the answer, in order (module docstring)."""
    n, m, b, c = len(a), len(a.contacts["depth"]), a.body, a.contacts
    label = ft.Labeller(a)
    out = [Column(("colliding",), n, lambda s, e: b["colliding"][s:e], "|b1"),
           Column(("point",), n, lambda s, e: b["point"][s:e], "<f8", (3,)),
           Column(("normal",), n, lambda s, e: b["normal"][s:e], "<f8", (3,)),
           Column(("depth",), n, lambda s, e: b["depth"][s:e], "<f8"),
           Column(("distance",), n, lambda s, e: b["distance"][s:e], "<f8"),
           Column(("closest_a",), n, lambda s, e: b["closest_a"][s:e], "<f8", (3,)),
           Column(("closest_b",), n, lambda s, e: b["closest_b"][s:e], "<f8", (3,)),
           Column(("contact_type",), n, lambda s, e: CONTACT_NAMES[b["contact_type"][s:e]],
                  TYPE_DTYPE)]
    for side in "ab":
        out += _feature_columns(a, (f"feature_{side}",), b[f"part_{side}"],
                                b[f"feature_{side}"], n, True, label)
    out += [Column(("predictor",), n, lambda s, e: a.predictor_names[a.predictor[s:e]],
                   PREDICTOR_DTYPE),
            Column(("confidence",), n, lambda s, e: b["confidence"][s:e], "<f8"),
            Column(("cluster_size",), n, lambda s, e: b["cluster_size"][s:e], "<i8")]
    if "paper_angles" in include:
        out.append(Column(("paper_angles",), n, lambda s, e: paper_angles(a, pairs, s, e),
                          "<f8", (4,)))
    out += [Column(("contacts", "offsets"), n + 1, lambda s, e: a.offsets[s:e], "<i8"),
            Column(("contacts", "part_a"), m, lambda s, e: _names(a.part_names,
                                                                  c["part_a"][s:e]), "<U64"),
            Column(("contacts", "part_b"), m, lambda s, e: _names(a.part_names,
                                                                  c["part_b"][s:e]), "<U64"),
            Column(("contacts", "point"), m, lambda s, e: c["point"][s:e], "<f8", (3,)),
            Column(("contacts", "normal"), m, lambda s, e: c["normal"][s:e], "<f8", (3,)),
            Column(("contacts", "depth"), m, lambda s, e: c["depth"][s:e], "<f8"),
            Column(("contacts", "contact_type"), m,
                   lambda s, e: CONTACT_NAMES[c["contact_type"][s:e]], TYPE_DTYPE)]
    for side in "ab":
        out += _feature_columns(a, ("contacts", f"feature_{side}"), c[f"part_{side}"],
                                c[f"feature_{side}"], m, False, label)
    out += [Column(("contacts", "axis"), m, lambda s, e: c["axis"][s:e], "|i1"),
            Column(("contacts", "pressure"), m, lambda s, e: c["pressure"][s:e], "<f8")]
    if "manifold" in include:
        out += [Column(("contacts", "manifold_count"), m,
                       lambda s, e: c["manifold_count"][s:e], "|i1"),
                Column(("contacts", "manifold_points"), m,
                       lambda s, e: c["manifold_points"][s:e], "<f8", (8, 3)),
                Column(("contacts", "manifold_depths"), m,
                       lambda s, e: c["manifold_depths"][s:e], "<f8", (8,))]
    return out


def _json(values) -> bytes:
    """A slice as JSON text without its brackets: non-finite floats and missing names null."""
    if (isinstance(values, np.ndarray) and values.dtype.kind in "biuf"
            and (values.dtype.kind != "f" or np.isfinite(values).all())):
        return orjson.dumps(values, option=orjson.OPT_SERIALIZE_NUMPY)[1:-1]
    return orjson.dumps(_python(values))[1:-1]  # null rows, names


def _slices(column: Column) -> Iterator:
    for start in range(0, column.rows, STREAM_ROWS):
        yield column.read(start, min(column.rows, start + STREAM_ROWS))


def _framing(columns_: list[Column]) -> Iterator[tuple[bytes, Column, bytes]]:
    """(opening, column, closing): the keys and the braces of the nested objects."""
    previous: tuple = ()
    for k, column in enumerate(columns_):
        path = column.path
        shared = 0
        while shared < min(len(path), len(previous)) - 1 and path[shared] == previous[shared]:
            shared += 1
        opened = path[shared:-1]  # the nested objects this column opens
        keys = [b'"%s":{' % p.encode() for p in opened] + [b'"%s":' % path[-1].encode()]
        # one comma after the previous value; an object opened here starts with its key
        opening = b"," + b"".join(keys)
        following = columns_[k + 1].path if k + 1 < len(columns_) else ()
        keep = 0
        while keep < min(len(path), len(following)) - 1 and path[keep] == following[keep]:
            keep += 1
        yield opening, column, b"}" * (len(path) - 1 - keep)
        previous = path


def batch_json(a: Answers, pairs: Pairs, include, mode: str,
               model_version: str) -> Iterator[bytes]:
    """The batch's columnar JSON in pieces (module docstring)."""
    head = b'{"n":%d,"mode":%s,"model_version":%s' % (len(a), orjson.dumps(mode),
                                                        orjson.dumps(model_version))
    items = ((opening, (_json(v) for v in _slices(column)), closing)
             for opening, column, closing in _framing(columns(a, pairs, include)))
    return json_pieces(head, items, b"}")


def _member(path: tuple) -> str:
    return "_".join(path) if path[0] != "contacts" else "contact_" + "_".join(path[1:])


def batch_npz(a: Answers, pairs: Pairs, include, mode: str, model_version: str,
              head=()) -> Iterator[bytes]:
    """The batch's npz archive in pieces (module docstring); ``head``: members written first,
    each (name, array)."""
    def text(value: str):
        return f"<U{max(1, len(value))}", (), iter([np.asarray(value)])

    def members():
        for name, array in head:
            yield name, array.dtype.str, array.shape, iter([array])
        yield ("n", "<i8", (), iter([np.asarray(len(a))]))
        yield ("mode", *text(mode))
        yield ("model_version", *text(model_version))
        for column in columns(a, pairs, include):
            slices = (np.where(v == None, "", v) if v.dtype == object else v  # noqa: E711
                      for v in _slices(column))
            yield _member(column.path), column.dtype, (column.rows, *column.shape), slices

    return npz_pieces(members())


def _python(values) -> list:
    """A slice as JSON-ready Python values (what :func:`_json` writes): a row with a NaN or
    inf is one None, missing names None."""
    if isinstance(values, np.ndarray) and values.dtype.kind in "biuf":
        listed = values.tolist()
        if values.dtype.kind == "f" and not np.isfinite(values).all():
            known = np.isfinite(values).reshape(len(values), -1).all(axis=1)
            listed = [row if ok else None for row, ok in zip(listed, known.tolist(), strict=True)]
        return listed
    return np.asarray(values, dtype=object).tolist()


def _finite(values: np.ndarray) -> list:
    """A column's rows (k, ...) as JSON-ready Python values: a float row holding a NaN or an
    infinity is one None (as :func:`_python`), checked in Python: a single pair's answer has a
    handful of values, and a NumPy call per column would cost more than the whole check."""
    listed = values.tolist()
    if values.dtype.kind != "f":
        return listed
    if values.ndim == 1:
        return [v if isfinite(v) else None for v in listed]
    flat = (lambda row: row) if values.ndim == 2 else (lambda row: chain.from_iterable(row))
    return [row if all(map(isfinite, flat(row))) else None for row in listed]


def _feature(label, part: int, feature_id: int) -> dict:
    name, kind = label(part, feature_id)
    return {"id": feature_id, "name": name, "kind": kind}


def _contact_rows(a: Answers, label, include) -> list[dict]:
    """Every part contact as a single pair's contact object (module docstring)."""
    c = a.contacts
    part_names = a.part_names.tolist()
    part_a, part_b = c["part_a"].tolist(), c["part_b"].tolist()
    feature_a, feature_b = c["feature_a"].tolist(), c["feature_b"].tolist()
    point, normal, depth = _finite(c["point"]), _finite(c["normal"]), _finite(c["depth"])
    types, axis, pressure = c["contact_type"].tolist(), c["axis"].tolist(), _finite(c["pressure"])
    manifold = "manifold" in include
    if manifold:
        count = c["manifold_count"].tolist()
        points, depths = _finite(c["manifold_points"]), _finite(c["manifold_depths"])
    out = []
    for j in range(len(depth)):
        row = {"part_a": part_names[part_a[j]] if part_a[j] >= 0 else None,
               "part_b": part_names[part_b[j]] if part_b[j] >= 0 else None,
               "point": point[j], "normal": normal[j], "depth": depth[j],
               "contact_type": CONTACT_TYPES[types[j]],
               "feature_a": _feature(label, part_a[j], feature_a[j]),
               "feature_b": _feature(label, part_b[j], feature_b[j]),
               "axis": axis[j], "pressure": pressure[j]}
        if manifold:
            k = count[j]
            row["manifold"] = {"count": k, "points": points[j][:k], "depths": depths[j][:k]}
        out.append(row)
    return out


def rows_json(a: Answers, pairs: Pairs, include) -> list[dict]:
    """Every row as a single pair's answer (module docstring), without mode and version: the
    keys and values of the batch's columns (:func:`columns`) for that row, in their order."""
    b, label = a.body, ft.Labeller(a)
    part_names = a.part_names.tolist()
    contacts, offsets = _contact_rows(a, label, include), a.offsets.tolist()
    listed = {k: _finite(b[k]) for k in ("colliding", "point", "normal", "depth", "distance",
                                         "closest_a", "closest_b", "confidence",
                                         "cluster_size")}
    types, predictors = b["contact_type"].tolist(), a.predictor_names[a.predictor].tolist()
    angles = _finite(paper_angles(a, pairs, 0, len(a))) if "paper_angles" in include else None
    sides = [(f"feature_{s}", b[f"part_{s}"].tolist(), b[f"feature_{s}"].tolist())
             for s in "ab"]
    out = []
    for i in range(len(a)):
        row = {k: listed[k][i] for k in ("colliding", "point", "normal", "depth", "distance",
                                         "closest_a", "closest_b")}
        row["contact_type"] = CONTACT_TYPES[types[i]]
        for key, parts, ids in sides:
            part = parts[i]
            row[key] = {"part": part_names[part] if part >= 0 else None,
                        **_feature(label, part, ids[i])}
        row |= {"predictor": predictors[i], "confidence": listed["confidence"][i],
                "cluster_size": listed["cluster_size"][i]}
        if angles is not None:
            row["paper_angles"] = angles[i]
        row["contacts"] = contacts[offsets[i]:offsets[i + 1]]
        out.append(row)
    return out


def row_json(a: Answers, pairs: Pairs, include) -> dict:
    """A single pair's answer (module docstring), without mode and version."""
    return rows_json(a, pairs, include)[0]
