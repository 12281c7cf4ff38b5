"""npz archives read and written in one pass (service/codecs/npz_format.py): what they read
equals ``numpy.load``'s, what they write ``numpy.load`` reads back, with zip64 records and
streamed members, and what the fast reader does not know goes to ``numpy.load``."""
from __future__ import annotations

import io
import struct
import zipfile

import numpy as np
import pytest

from impactnet.service.codecs import npz_format as nf


def _arrays(seed: int = 0) -> dict[str, np.ndarray]:
    """Members of every kind an answer or a request carries, and the odd shapes."""
    rng = np.random.default_rng(seed)
    return {"point": rng.normal(size=(7, 3)), "depth": rng.normal(size=7),
            "colliding": rng.random(7) > 0.5, "feature_a_id": rng.integers(-1, 26, 7, np.int32),
            "axis": rng.integers(-1, 15, 7).astype(np.int8),
            "offsets": np.arange(8, dtype=np.int64), "part": np.array(["box", "", "corner_fl"]),
            "manifold_points": rng.normal(size=(4, 8, 3)), "n": np.asarray(7),
            "mode": np.asarray("exact"), "empty": np.zeros((0, 3)),
            "fortran": np.asfortranarray(rng.normal(size=(3, 5))),
            "wide": rng.integers(0, 1 << 40, size=5, dtype=np.uint64)}


def _loaded(data: bytes) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(data), allow_pickle=False) as archive:
        return {name: archive[name] for name in archive.files}


def _same(got: dict, expected: dict) -> None:
    assert list(got) == list(expected)
    for name, array in expected.items():
        assert got[name].dtype == array.dtype and got[name].shape == array.shape, name
        np.testing.assert_array_equal(got[name], array, err_msg=name)


@pytest.fixture
def no_fallback(monkeypatch):
    """The fast path only: ``numpy.load`` may not be called."""
    def refused(*args, **kwargs):
        raise AssertionError("numpy.load was called")

    monkeypatch.setattr(nf.np, "load", refused)


def _savez(arrays: dict, compressed: bool = False) -> bytes:
    buffer = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buffer, **arrays)
    return buffer.getvalue()


def test_an_archive_of_numpy_savez_reads_as_numpy_load_reads_it(no_fallback):
    arrays = _arrays()
    data = _savez(arrays)
    got = nf.read_npz(data)
    _same(got, arrays)
    assert all(a.flags.writeable and a.flags.aligned for a in got.values())


def test_what_write_npz_writes_numpy_load_reads_back_and_zipfile_finds_sound():
    arrays = _arrays(1)
    data = nf.write_npz(arrays)
    _same(_loaded(data), {k: np.array(v, order="C") for k, v in arrays.items()})
    assert zipfile.ZipFile(io.BytesIO(data)).testzip() is None  # every CRC-32 right


@pytest.mark.parametrize("piece_bytes", [1, 100, 1 << 20])
@pytest.mark.parametrize("zip64_from", [nf.ZIP64_FROM, 64])
def test_a_streamed_archive_reads_alike_in_numpy_load_and_the_fast_reader(
        piece_bytes, zip64_from, monkeypatch):
    monkeypatch.setattr(nf, "ZIP64_FROM", zip64_from)  # 64: every member and offset zip64
    arrays = _arrays(2)
    members = [(name, a.dtype.str, a.shape,
                iter([a[:2], a[2:]]) if a.ndim else iter([a]))
               for name, a in arrays.items()]
    data = b"".join(nf.npz_stream(iter(members), piece_bytes))
    expected = {k: np.array(v, order="C") for k, v in arrays.items()}
    _same(_loaded(data), expected)
    assert zipfile.ZipFile(io.BytesIO(data)).testzip() is None
    load = np.load
    monkeypatch.setattr(nf.np, "load", lambda *a, **k: pytest.fail("numpy.load was called"))
    _same(nf.read_npz(data), expected)
    monkeypatch.setattr(nf.np, "load", load)


def test_a_compressed_archive_is_read_by_numpy_load():
    arrays = _arrays(3)
    _same(nf.read_npz(_savez(arrays, compressed=True)), arrays)


def test_a_member_with_a_wrong_crc_is_refused():
    data = bytearray(_savez({"depth": np.arange(40.0)}))
    data[data.index(b"NUMPY") + 80] ^= 1  # one bit of the member's data
    with pytest.raises((ValueError, zipfile.BadZipFile)):
        nf.read_npz(bytes(data))


def test_an_object_member_is_refused_as_numpy_load_refuses_it():
    data = _savez({"names": np.array(["a", None], dtype=object)})
    with pytest.raises(ValueError, match="allow_pickle"):
        nf.read_npz(data)


@pytest.mark.parametrize("count", [0, 3])
def test_an_end_record_that_counts_fewer_members_hides_none(count):
    arrays = {"a": np.arange(3.0), "f": np.ones(2, bool), "z": np.zeros((2, 2))}
    data = bytearray(_savez(arrays))
    end = data.rindex(b"PK\x05\x06")
    data[end + 8:end + 12] = struct.pack("<2H", count, count)  # entries on disk, in all
    expected = _loaded(bytes(data))
    assert list(expected) == list(arrays)  # zipfile walks the directory, not the count
    _same(nf.read_npz(bytes(data)), expected)


def test_a_truncated_member_is_read_or_refused_as_numpy_load_does():
    data = _savez({"a": np.arange(3.0)})
    cut = data.index(b"NUMPY") + 2
    damaged = data[:cut] + data[cut + 60:]
    with pytest.raises(Exception) as ours:
        nf.read_npz(damaged)
    with pytest.raises(Exception) as theirs:
        _loaded(damaged)
    assert type(ours.value) is type(theirs.value)
