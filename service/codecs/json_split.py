"""The members of a JSON body's top-level object, found without parsing it.

Every batch a client library writes has a simple layout: one object of columns, no nested object, no
escaped character. There, the quotes pair up in order (no string holds a quote), a string is a key
exactly when the next character outside whitespace is a colon, and a member's value runs from its
key's colon to the comma before the next key. :func:`split_columns` finds the members that way, with
vectorised scans, so that each column can be counted and parsed on its own
(:mod:`impactnet.service.codecs.batch_json`); any body outside the layout gives None and is parsed
whole. The value slices are parsed strictly afterwards, so a body that is not valid JSON is never
accepted: every slice must be one JSON value, and between two members there must be exactly one
comma.
"""
from __future__ import annotations

import numpy as np

from impactnet.service.codecs import scan

_WHITESPACE = np.frombuffer(b" \t\r\n", np.uint8)
_COLON = ord(":")
#: Most strings followed by a colon or whitespace that are examined one by one: the keys (15
#: at most: 12 columns, 3 options) and a few values; a pretty-printed body has more (a space
#: after each name) and is parsed whole instead.
KEY_CANDIDATES_MAX = 64


def _strip(body: bytes, start: int, end: int) -> tuple[int, int]:
    while start < end and body[start] in b" \t\r\n":
        start += 1
    while end > start and body[end - 1] in b" \t\r\n":
        end -= 1
    return start, end


def _keys(body: bytes, last: int) -> list[tuple[str, int, int]] | None:
    """``(name, opening quote, end of the colon)`` of each key, or None."""
    quotes = scan.positions(body, ord('"'))
    if len(quotes) % 2:
        return None
    view = np.frombuffer(body, np.uint8)
    openings, closings = quotes[0::2], quotes[1::2]
    following = view[np.minimum(closings + 1, len(view) - 1)]
    candidates = np.flatnonzero((following == _COLON) | np.isin(following, _WHITESPACE))
    if len(candidates) > KEY_CANDIDATES_MAX:
        return None
    keys = []
    for i in candidates.tolist():
        opening, closing = int(openings[i]), int(closings[i])
        after, _ = _strip(body, closing + 1, last)
        if body[after:after + 1] == b":":
            keys.append((body[opening + 1:closing].decode("utf-8", "replace"), opening,
                         after + 1))
    return keys


def split_columns(body: bytes) -> list[tuple[str, int, int]] | None:
    """``(key, start, end)`` of the value of each member of the body's top-level object, in
    order, or None when the body is not in the simple layout (module docstring)."""
    if scan.contains(body, b"\\") or scan.count(body, b"{") != 1 or scan.count(body, b"}") != 1:
        return None
    first, last = _strip(body, 0, len(body))
    if first >= last or body[first] != ord("{") or body[last - 1] != ord("}"):
        return None
    keys = _keys(body, last)
    if not keys or _strip(body, first + 1, last)[0] != keys[0][1]:
        return None
    spans = []
    for (name, _, value_start), following in zip(keys, keys[1:] + [None], strict=True):
        start, end = _strip(body, value_start, following[1] if following else last - 1)
        if following is not None:
            if body[end - 1:end] != b",":
                return None
            start, end = _strip(body, start, end - 1)
        if start >= end:
            return None
        spans.append((name, start, end))
    return spans
