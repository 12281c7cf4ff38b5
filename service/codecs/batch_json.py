"""JSON batch bodies: parsed one column at a time, each column counted before it is parsed.

Parsing a whole JSON body into Python objects amplifies it: orjson took 16-36 times the body in
memory (its document tree plus the objects) and held the event loop's GIL for the whole parse;
pydantic-core's parser (jiter) builds the objects directly, in 4-13 times the body for numeric
columns and at most 29 times for hostile shapes (``[[],[],...]``), measured by peak RSS. So:

1. **split** (:func:`impactnet.service.codecs.json_split.split_columns`): the top-level object is
cut into its
   members by the positions of its quotes and colons, without parsing. This needs the simple
   layout of every batch we write: one ``{`` and one ``}``, no backslash; other bodies are
   parsed whole (:func:`_parse_whole`), under counts for the whole body and at most
   :data:`KEYS_MAX` colons (422 beyond). A key given twice is refused (422). A body with more
   strings than a batch of ``max_pairs`` pairs can hold is not split (listing its quotes
   would cost more than it is worth) but refused by those counts.
2. **count** (:func:`_column_cost`): each column's brackets, commas and quotes are counted (sliced
   ``bytes.count``, no copy), every column before any is parsed. Strings where numbers belong are
   422; then a column that could not hold at most ``max_pairs`` rows is 413, before parsing. The
   parse's memory is estimated from the counts (upper bounds measured with jiter, the constants
   below) and reserved in the request's memory lease, together with the column's float64 copy.
3. **parse** one column (jiter, no NaN / Infinity tokens; the cyclic garbage collector paused:
   it would otherwise walk the growing lists again and again, 2-3 times the parse's time) and
   convert it to a NumPy array at once, so that its Python objects are freed before the next
   column is parsed: the peak is one column's objects, and the GIL is released between
   columns (a 100,000-row column parses in ~25-50 ms).

jiter reads a number beyond float64 (``1e400``) as infinity; such a column is malformed JSON
(the tokens ``NaN`` and ``Infinity`` are refused by the parser itself).
"""
from __future__ import annotations

import contextlib
import gc
import threading

import numpy as np
from pydantic_core import from_json

from impactnet.service.codecs import scan
from impactnet.service.codecs.columns import (
    COLUMNS,
    OPTIONS,
    tail_of,
    too_many_pairs,
    unknown_column,
)
from impactnet.service.codecs.json_keys import check_no_duplicates
from impactnet.service.codecs.json_split import split_columns
from impactnet.service.errors import DuplicateKey, InputError, PayloadTooLarge
from impactnet.service.limits.budget import Lease

#: Upper bounds of jiter's peak memory (bytes, CPython 3.11, peak RSS of 1e6-item bodies):
#: per ``[`` or ``{`` (an empty list took 85 B), per value (a float in a flat list took 84 B
#: with the parser's growing buffer; 70 B in rows of 3), per string (88 B for a short name,
#: plus its characters, counted by the body's length).
LIST_BYTES = 96
VALUE_BYTES = 88
STRING_BYTES = 96
#: Bytes per value of the NumPy conversion: an int64 or float64 array and its float64 copy.
ARRAY_BYTES = 16
#: Brackets of one row of a column: 1 for vectors, 4 for a 3x3 matrix; values: the row's size.
_MATRIX_BRACKETS = 4
#: Most brackets and values one pair can take in a whole body: per side a size (1 bracket, 3
#: values), a position (1, 3) and a matrix (4, 9).
_PAIR_BRACKETS_MAX = 2 * (1 + 1 + _MATRIX_BRACKETS)
_PAIR_VALUES_MAX = 2 * (3 + 3 + 9)
#: Most strings per pair (the two object names) and besides them (keys, options' values).
_PAIR_STRINGS_MAX = 2
_OTHER_STRINGS_MAX = 64
#: Most colons in a body parsed whole: one per key, 15 keys at most (12 columns, 3 options),
#: and a few in object names. More (3 million unknown keys once took 35 s) is refused unparsed.
KEYS_MAX = 32
#: Longest body of an option (mode, include, euler_convention), in bytes.
OPTION_MAX_BYTES = 256

_gc_lock = threading.Lock()
_gc_pausers = 0  # threads parsing now
_gc_was_enabled = True  # the collector's state when the first of them began


@contextlib.contextmanager
def _gc_paused():
    """The cyclic garbage collector off while any thread parses (it is process-wide)."""
    global _gc_pausers, _gc_was_enabled
    with _gc_lock:
        if _gc_pausers == 0:
            _gc_was_enabled = gc.isenabled()
            gc.disable()
        _gc_pausers += 1
    try:
        yield
    finally:
        with _gc_lock:
            _gc_pausers -= 1
            if _gc_pausers == 0 and _gc_was_enabled:
                gc.enable()


def _loads(data: bytes, where: str):
    try:
        with _gc_paused():
            return from_json(data, allow_inf_nan=False, cache_strings=False)
    except ValueError as exc:
        raise InputError("body", f"malformed JSON{where}: {exc}", type_="json_invalid") from None


def _column_cost(name: str, body: bytes, start: int, end: int,
                 max_pairs: int) -> tuple[int, PayloadTooLarge | None]:
    """Bytes that parsing and converting the column needs, and the 413 to answer when it
    holds more than ``max_pairs`` rows (step 2); 422 at once when the column cannot be a
    valid one whatever its size."""
    brackets, commas = scan.count(body, b"[", start, end), scan.count(body, b",", start, end)
    strings = scan.count(body, b'"', start, end) // 2
    if name in OPTIONS:
        if end - start > OPTION_MAX_BYTES:
            raise InputError(name, f"longer than {OPTION_MAX_BYTES} bytes", type_="too_long")
        return 0, None
    tail = tail_of(name)
    if tail is None:  # object names: one string, or a list of them
        if brackets > 1:
            raise InputError(name, "expected an object name or an array of N names",
                             type_="string_type")
        over = too_many_pairs(strings, max_pairs) if strings > max_pairs else None
        return LIST_BYTES + strings * STRING_BYTES + (end - start) * 4, over
    if strings:
        raise InputError(name, "expected numbers, got strings", type_="float_type")
    per_row = _MATRIX_BRACKETS if len(tail) == 2 else 1
    values = commas + 1
    width = int(np.prod(tail))
    over = None
    if brackets > per_row * max_pairs + 1 or values > width * max_pairs:
        over = too_many_pairs(max(brackets // per_row, values // width), max_pairs)
    return brackets * LIST_BYTES + values * (VALUE_BYTES + ARRAY_BYTES), over


def _as_array(name: str, value) -> np.ndarray:
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as exc:  # nested lists of unequal lengths
        raise InputError(name, "ragged: its rows do not all have the same length",
                         type_="ragged") from exc
    if array.dtype.kind == "f" and np.isinf(array).any():
        raise InputError("body", f"malformed JSON: a number in {name} is beyond float64",
                         type_="json_invalid")
    return array


def _parse_column(name: str, body: bytes, start: int, end: int, cost: int, lease: Lease):
    lease.reserve(cost, f"parsing column {name}")
    kept = 0
    try:
        value = _loads(body[start:end], f" in {name}")
        if name in OPTIONS:
            return value
        array = _as_array(name, value)
        kept = min(cost, array.nbytes)  # the array stays; the parse's objects are gone
        return array
    finally:
        lease.give_back(cost - kept)


def _strings_max(max_pairs: int) -> int:
    """Most strings in a batch of ``max_pairs`` pairs: two names per pair, keys, options."""
    return _PAIR_STRINGS_MAX * max_pairs + _OTHER_STRINGS_MAX


def _too_big(what: str, count: int, max_pairs: int) -> PayloadTooLarge:
    return PayloadTooLarge("batch_too_large", f"the body holds {count} {what}, more than a "
                           f"batch of at most {max_pairs} pairs can")


def _parse_whole(body: bytes, max_pairs: int, lease: Lease) -> dict:
    """A body outside the simple layout: parsed at once, under counts for the whole (422 for
    more keys than a batch has, 413 for more brackets, values or strings than
    ``max_pairs`` pairs can hold)."""
    colons = scan.count(body, b":")
    if colons > KEYS_MAX:
        raise InputError("body", f"{colons} keys: a batch is one JSON object of at most "
                         f"{len(COLUMNS)} columns and {len(OPTIONS)} options",
                         type_="too_many_keys")
    brackets = scan.count(body, b"[") + scan.count(body, b"{")
    values = scan.count(body, b",") + 1
    strings = scan.count(body, b'"') // 2
    if brackets > _PAIR_BRACKETS_MAX * (max_pairs + 1):
        raise _too_big("brackets", brackets, max_pairs)
    if values > _PAIR_VALUES_MAX * (max_pairs + 1):
        raise _too_big("values", values, max_pairs)
    if strings > _strings_max(max_pairs):
        raise _too_big("strings", strings, max_pairs)
    lease.reserve(brackets * LIST_BYTES + values * (VALUE_BYTES + ARRAY_BYTES)
                  + strings * STRING_BYTES + len(body), "parsing the JSON body")
    data = _loads(body, "")
    if not isinstance(data, dict):
        raise InputError("body", "expected a JSON object of columns", type_="json_type")
    check_no_duplicates(body, len(data))
    return {k: _as_array(k, v) if k in COLUMNS else v for k, v in data.items()}


def parse_json_batch(body: bytes, max_pairs: int, lease: Lease) -> tuple[dict, dict]:
    """``(columns, options)`` of a JSON batch body: columns as NumPy arrays (module
    docstring). Raises InputError / DuplicateKey (422), PayloadTooLarge (413), Overloaded
    (503)."""
    # The split lists every quote: only for a body with no more strings than a batch has.
    few_strings = scan.count(body, b'"') // 2 <= _strings_max(max_pairs)
    spans = split_columns(body) if few_strings else None
    if spans is None:
        data = _parse_whole(body, max_pairs, lease)
        options = {k: data.pop(k) for k in OPTIONS if k in data}
        return data, options
    costs, seen = [], set()
    for name, start, end in spans:  # every column counted first: a 422 wins over a 413
        if name in seen:
            raise DuplicateKey(name)
        seen.add(name)
        if name not in COLUMNS and name not in OPTIONS:
            raise unknown_column(name)
        costs.append((name, start, end, *_column_cost(name, body, start, end, max_pairs)))
    for *_, over in costs:
        if over is not None:
            raise over
    columns, options = {}, {}
    for name, start, end, cost, _ in costs:
        value = _parse_column(name, body, start, end, cost, lease)
        (options if name in OPTIONS else columns)[name] = value
    return columns, options
