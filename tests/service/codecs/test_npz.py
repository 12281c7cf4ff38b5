"""An npz request body (service/codecs/npz.py) read in one pass where its members are stored:
what it accepts equals ``numpy.load``'s reading, and every damaged or hostile archive is a 4xx
naming the fault, never a crash or an allocation beyond the body."""
from __future__ import annotations

import io
import struct
import zipfile

import numpy as np
import pytest

from impactnet.service.codecs import npz_format as nf
from impactnet.service.codecs.npz import parse_npz
from impactnet.service.errors import InputError, PayloadTooLarge
from impactnet.service.limits.budget import Lease, MemoryBudget

#: A request's columns (a batch of 5 pairs).
COLUMNS = {"a_size": np.full((5, 3), 2.0), "a_position": np.zeros((5, 3)),
           "a_quaternion": np.tile([1.0, 0, 0, 0], (5, 1)), "b_object": np.array("cube"),
           "b_position": np.arange(15.0).reshape(5, 3), "b_euler": np.zeros((5, 3))}


def _parsed(body: bytes, max_bytes: int = 1 << 20) -> dict:
    return parse_npz(body, max_bytes, 1000, Lease(MemoryBudget(1 << 30, 0.0, 1)))


def _savez(columns: dict) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    return buffer.getvalue()


def test_a_stored_archive_is_read_in_one_pass_as_numpy_load_reads_it(monkeypatch):
    body = _savez(COLUMNS)
    monkeypatch.setattr(zipfile, "ZipFile", lambda *a, **k: pytest.fail("zipfile was used"))
    got = _parsed(body)
    assert list(got) == list(COLUMNS)
    for name, array in COLUMNS.items():
        assert got[name].dtype == array.dtype and got[name].shape == array.shape
        np.testing.assert_array_equal(got[name], array)


def test_the_clients_archive_is_read_alike():
    got = _parsed(nf.write_npz(COLUMNS))
    for name, array in COLUMNS.items():
        np.testing.assert_array_equal(got[name], array)


def _member_sizes_patched(body: bytes, size: int) -> bytes:
    """The body with the first central-directory entry's sizes set to ``size``."""
    data = bytearray(body)
    at = data.index(b"PK\x01\x02")
    struct.pack_into("<2I", data, at + 20, size, size)
    return bytes(data)


@pytest.mark.parametrize("size", [0, 10, 1 << 30])
def test_a_member_that_claims_another_size_is_refused(size):
    with pytest.raises((InputError, PayloadTooLarge)) as caught:
        _parsed(_member_sizes_patched(_savez(COLUMNS), size), max_bytes=1 << 31)
    assert caught.value.status_code in (413, 422)


def test_a_member_with_a_wrong_crc_is_a_422():
    data = bytearray(_savez(COLUMNS))
    data[data.index(b"NUMPY") + 200] ^= 1  # a bit of a_size's data
    with pytest.raises(InputError, match="CRC"):
        _parsed(bytes(data))


@pytest.mark.parametrize("shape", ["(-5, 3)", "(4000000000000, 3)"])
def test_a_header_with_an_impossible_shape_is_a_422_before_any_allocation(shape):
    text = _savez({"a_position": np.zeros((5, 3))})
    data = text.replace(b"(5, 3)", shape.encode().ljust(6)[:max(6, len(shape))])
    with pytest.raises(InputError):
        _parsed(data)


def test_an_object_member_is_refused_naming_its_column():
    columns = {**COLUMNS, "b_object": np.array(["cube", None], dtype=object)}
    with pytest.raises(InputError) as caught:
        _parsed(_savez(columns))
    assert caught.value.items[0]["field"] == "b_object"
