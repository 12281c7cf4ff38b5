"""The batch answer's JSON paths as npz member names, and the check that a JSON answer and an npz
answer carry the same members and values (not a test module).

A JSON column at path ``(key, ...)`` is the npz member ``key_...``; a part contact's column,
under ``contacts``, is ``contact_...`` (``contacts.feature_b.kind``: ``contact_feature_b_kind``).
JSON's nulls are npz's missing values: an infinite distance (beyond the margin), NaN rows (no
closest points, no angles), empty names.
"""
from __future__ import annotations

import numpy as np


def member_name(path: tuple[str, ...]) -> str:
    """The npz member of a JSON column's path."""
    if path[0] == "contacts":
        return "contact_" + "_".join(path[1:])
    return "_".join(path)


def json_members(answer: dict) -> dict[str, object]:
    """Every column and scalar of a JSON batch answer, by its npz member name."""
    out: dict[str, object] = {}

    def walk(value, path: tuple[str, ...]) -> None:
        if isinstance(value, dict):
            for key, inner in value.items():
                walk(inner, (*path, key))
        else:
            out[member_name(path)] = value

    walk(answer, ())
    return out


def _missing(name: str) -> float:
    return np.inf if name == "distance" else np.nan


def assert_same_column(name: str, values, array: np.ndarray) -> None:
    """One JSON column (or scalar) equals its npz member, nulls read as npz writes them."""
    if array.ndim == 0:
        assert values == array.item(), name
        return
    assert len(values) == len(array), name
    if array.dtype.kind == "U":
        assert array.tolist() == ["" if v is None else v for v in values], name
        return
    if array.dtype.kind == "f":
        rows = [np.full(array.shape[1:], _missing(name)) if v is None else v for v in values]
        expected = np.array(rows, dtype=np.float64).reshape(array.shape)
    else:
        assert None not in values, name
        expected = np.asarray(values).reshape(array.shape)
    np.testing.assert_array_equal(expected, array, err_msg=name)


def assert_same_answer(text: dict, binary: dict) -> None:
    """A JSON batch answer and an npz one carry the same members with the same values."""
    members = json_members(text)
    assert set(members) == set(binary), set(members) ^ set(binary)
    for name, values in members.items():
        assert_same_column(name, values, binary[name])
