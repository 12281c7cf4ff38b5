"""Answers sent as a stream (service/codecs/stream.py): an npz archive is cut into pieces of
about PIECE_BYTES, never one piece per member (each piece is a thread hop and a send: a
frame's answer of ~50 small members once paid ~10 ms for them)."""
from __future__ import annotations

import io

import numpy as np

from impactnet.service.codecs.stream import PIECE_BYTES, npz_pieces


def _slices(array: np.ndarray, rows: int):
    return (array[k:k + rows] for k in range(0, max(len(array), 1), rows))


def _members(arrays: dict[str, np.ndarray], rows: int):
    """npz_pieces's members: each array in slices of ``rows`` rows."""
    return [(name, a.dtype, a.shape, _slices(a, rows)) for name, a in arrays.items()]


def _read(pieces: list[bytes]) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(b"".join(pieces)), allow_pickle=False) as npz:
        return {name: npz[name] for name in npz.files}


def test_an_archive_of_many_small_members_is_one_piece():
    rng = np.random.default_rng(0)
    arrays = {f"m{k}": rng.normal(size=(7, 3)) for k in range(50)}
    arrays["names"] = np.array(["box", "spreader"], "<U24")
    pieces = list(npz_pieces(_members(arrays, 4)))
    assert len(pieces) == 1
    read = _read(pieces)
    assert read.keys() == arrays.keys()
    for name, array in arrays.items():
        np.testing.assert_array_equal(read[name], array)


def test_a_large_archive_is_cut_into_pieces_of_about_the_piece_size():
    rng = np.random.default_rng(1)
    arrays = {"a": rng.normal(size=(300_000, 3)), "b": rng.normal(size=(100_000,)),
              "c": np.arange(10)}
    rows = 4096
    pieces = list(npz_pieces(_members(arrays, rows)))
    total = sum(len(p) for p in pieces)
    assert total // PIECE_BYTES <= len(pieces) <= total // PIECE_BYTES + 1
    assert all(len(p) < PIECE_BYTES + rows * 3 * 8 + 4096 for p in pieces)  # one slice over
    read = _read(pieces)
    for name, array in arrays.items():
        np.testing.assert_array_equal(read[name], array)
