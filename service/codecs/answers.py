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

import numpy as np
import orjson

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


def _feature_columns(a: Answers, prefix: tuple, parts, ids, rows, body: bool, tables) -> list:
    last: dict = {}  # the labels of the last slice read: names and kinds labelled once

    def labelled(start, stop):
        if last.get("slice") != (start, stop):
            last["slice"] = (start, stop)
            last["labels"] = ft.labels(a, parts[start:stop], ids[start:stop], tables)
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
    tables = ft.tables_of(a)
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
                                b[f"feature_{side}"], n, True, tables)
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
                                c[f"feature_{side}"], m, False, tables)
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


def _put(target: dict, path: tuple, value) -> None:
    for key in path[:-1]:
        target = target.setdefault(key, {})
    target[path[-1]] = value


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


def _listed(column: Column) -> list:
    """A whole column as JSON-ready Python values (names, numbers, None)."""
    if column.rows <= STREAM_ROWS:  # one slice (a single pair's answer)
        return _python(column.read(0, column.rows))
    return [value for v in _slices(column) for value in _python(v)]


def rows_json(a: Answers, pairs: Pairs, include) -> list[dict]:
    """Every row as a single pair's answer (module docstring), without mode and version:
    each column converted once, then dealt out to the rows."""
    out: list[dict] = [{} for _ in range(len(a))]
    contacts: list[dict] = [{} for _ in range(len(a.contacts["depth"]))]
    offsets = a.offsets.tolist()
    for column in columns(a, pairs, include):
        path = column.path
        if path == ("contacts", "offsets"):
            continue
        values = _listed(column)
        targets = contacts if path[0] == "contacts" else out
        for target, value in zip(targets, values, strict=True):
            _put(target, path[1:] if path[0] == "contacts" else path, value)
    for row in contacts:
        if "manifold_count" in row:
            k = row.pop("manifold_count")
            row["manifold"] = {"count": k, "points": row.pop("manifold_points")[:k],
                               "depths": row.pop("manifold_depths")[:k]}
    for i, row in enumerate(out):
        row["contacts"] = contacts[offsets[i]:offsets[i + 1]]
    return out


def row_json(a: Answers, pairs: Pairs, include) -> dict:
    """A single pair's answer (module docstring), without mode and version."""
    return rows_json(a, pairs, include)[0]
