"""Issue 23, item 4: a column of zero rows is the documented 422 ``empty batch``, never a 500.

Reproducer: an npz whose ``b_position`` has shape (0, 3) raised ``ValueError: cannot reshape
array of size 0`` in service/codecs/columns.py (``reshape(len(rows), -1)`` is ambiguous for zero
rows). Every column kind and both encodings are covered: each shape that can reach a reshape.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.service.conftest import assert_error
from tests.service.test_batch import as_json, npz_bytes, poses

URL = "/v2/contact/batch"
NPZ = {"Content-Type": "application/x-npz"}

EMPTY_NPZ = [
    ("b_position", np.zeros((0, 3))),
    ("b_position", np.zeros((0, 3), np.int8)),
    ("a_size", np.zeros((0, 3), np.uint16)),
    ("a_quaternion", np.zeros((0, 4), np.float32)),
    ("b_euler", np.zeros((0, 3))),
    ("a_matrix", np.zeros((0, 3, 3))),
    ("a_object", np.zeros(0, "<U8")),
]


def _broadcast_columns() -> dict:
    """One pair's columns, every one a single value (broadcast)."""
    columns = poses(1, seed=3)
    return {k: (v[0] if v.ndim == 2 else v) for k, v in columns.items()}


def _replace(columns: dict, name: str, value) -> dict:
    side, kind = name.split("_", 1)
    out = dict(columns)
    if kind in ("euler", "matrix"):
        out.pop(f"{side}_quaternion")
    if kind == "object":
        out.pop(f"{side}_size")
    out[name] = value
    return out


@pytest.mark.parametrize("name,value", EMPTY_NPZ, ids=[f"{n}{v.shape}{v.dtype}"
                                                       for n, v in EMPTY_NPZ])
def test_zero_rows_in_npz_is_422_empty_batch(client, name, value):
    body = npz_bytes(_replace(_broadcast_columns(), name, value))
    answer = assert_error(client.post(URL, content=body, headers=NPZ), 422, name,
                          "invalid_input")
    assert "empty batch" in answer["message"]


@pytest.mark.parametrize("name", ["b_position", "a_size", "a_quaternion", "b_euler",
                                  "a_matrix", "a_object"])
def test_zero_rows_in_json_is_422_empty_batch(client, name):
    body = as_json(_replace(_broadcast_columns(), name, []))
    answer = assert_error(client.post(URL, json=body), 422, name, "invalid_input")
    assert "empty batch" in answer["message"]


def test_zero_rows_beside_a_full_column_is_ragged(client):
    columns = _broadcast_columns() | {"a_position": np.zeros((2, 3)),
                                      "b_position": np.zeros((0, 3))}
    answer = assert_error(client.post(URL, content=npz_bytes(columns), headers=NPZ), 422,
                          None, "invalid_input")
    assert "ragged" in answer["message"]
