"""npz archives (an uncompressed zip of ``.npy`` members) read and written in one pass over the
bytes, without :mod:`zipfile`'s and ``numpy.load``'s per-member work (a frame's answer has ~50
small members: ``numpy.load`` spent ~45 us on each).

:func:`read_npz` reads what ``numpy.savez`` and the service's streamed answers write (stored
members, zip64 or not, sizes in the central directory or in data descriptors); anything else
(compressed members, structured dtypes, an unexpected header) is read by ``numpy.load``, so
that the result never depends on the path. Each member's CRC-32 is checked, as ``zipfile``
does. :func:`npz_stream` writes members given slice by slice (a server's answer, streamed),
zip64 records where an offset or a size needs them; :func:`write_npz` writes whole arrays (a
client's request) through it. ``numpy.load`` reads both.
"""
from __future__ import annotations

import io
import math
import re
import struct
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

_EOCD, _EOCD64, _LOCATOR = b"PK\x05\x06", b"PK\x06\x06", b"PK\x06\x07"
_CENTRAL, _LOCAL = b"PK\x01\x02", b"PK\x03\x04"
_CENTRAL_ENTRY = struct.Struct("<4s6H3I5H2I")  # 46 bytes
_LOCAL_ENTRY = struct.Struct("<4s5H3I2H")  # 30 bytes
_ZIP64_EXTRA = 0x0001
_FULL32, _FULL16 = 0xFFFFFFFF, 0xFFFF
_DESCRIPTOR = b"PK\x07\x08"
#: Offsets and sizes from this many bytes on are written in zip64 records (the zip format's
#: 32-bit fields end at 0xFFFFFFFF, which marks a value given in the zip64 extra field).
ZIP64_FROM = _FULL32
_NPY_MAGIC = b"\x93NUMPY"
#: Largest ``.npy`` header read, bytes (numpy writes ~128; numpy.load's own limit is 10,000).
NPY_HEADER_MAX = 10_000
_DESCR = re.compile(r"""['"]descr['"]\s*:\s*['"]([^'"]+)['"]""")
_FORTRAN = re.compile(r"""['"]fortran_order['"]\s*:\s*(True|False)""")
_SHAPE = re.compile(r"""['"]shape['"]\s*:\s*\(([^)]*)\)""")


class Unusual(Exception):
    """Not what the one-pass reader reads (compressed members, structured dtypes, another
    header): ``numpy.load`` or ``zipfile`` reads it."""


def _zip64_values(extra: bytes, wanted: int) -> list[int]:
    """The first ``wanted`` 8-byte values of a zip64 extra field."""
    at = 0
    while at + 4 <= len(extra):
        key, size = struct.unpack_from("<2H", extra, at)
        if key == _ZIP64_EXTRA:
            if size < 8 * wanted:
                raise Unusual()
            return list(struct.unpack_from(f"<{wanted}Q", extra, at + 4))
        at += 4 + size
    raise Unusual()


def _directory(data: memoryview) -> tuple[int, int, int]:
    """(offset, entries, size in bytes) of the central directory."""
    end = bytes(data[-(22 + _FULL16):]).rfind(_EOCD)
    if end < 0:
        raise Unusual()
    end += max(0, len(data) - (22 + _FULL16))
    entries, size, offset = struct.unpack_from("<H2I", data, end + 10)
    if _FULL32 in (size, offset) or entries == _FULL16:
        locator = end - 20
        if locator < 0 or bytes(data[locator:locator + 4]) != _LOCATOR:
            raise Unusual()
        (record,) = struct.unpack_from("<Q", data, locator + 8)
        if bytes(data[record:record + 4]) != _EOCD64:
            raise Unusual()
        entries, size, offset = struct.unpack_from("<3Q", data, record + 32)
    return offset, entries, size


def _members(data: memoryview):
    """(name, start, size, crc) of every member's bytes; the entries must fill the central
    directory exactly (a count that says fewer would hide members: ``zipfile`` reads them)."""
    at, entries, directory = _directory(data)
    end = at + directory
    for _ in range(entries):
        (signature, _, _, flags, method, _, _, crc, packed, size, name_length, extra_length,
         comment_length, _, _, _, local) = _CENTRAL_ENTRY.unpack_from(data, at)
        if signature != _CENTRAL or method != 0 or flags & 1 or packed != size:
            raise Unusual()
        name = bytes(data[at + 46:at + 46 + name_length]).decode()
        extra = bytes(data[at + 46 + name_length:at + 46 + name_length + extra_length])
        if _FULL32 in (size, local):  # zip64: the values marked full, in this order
            values = iter(_zip64_values(extra, (size == _FULL32) * 2 + (local == _FULL32)))
            size = next(values) if size == _FULL32 else size
            if packed == _FULL32:
                next(values)
            local = next(values) if local == _FULL32 else local
        header = _LOCAL_ENTRY.unpack_from(data, local)
        if header[0] != _LOCAL:
            raise Unusual()
        start = local + 30 + header[9] + header[10]
        at += 46 + name_length + extra_length + comment_length
        if at > end:
            raise Unusual()
        yield name, start, size, crc
    if at != end:
        raise Unusual()


@dataclass(frozen=True)
class Member:
    """A stored member of an archive: its name and where its bytes are."""

    name: str  # as stored, ``.npy`` included
    start: int  # offset of its bytes in the archive
    size: int  # its bytes
    crc: int  # their CRC-32, from the central directory


def stored_members(data: bytes) -> list[Member]:
    """Every member of an archive of stored members (raises :class:`Unusual` for another
    archive, ``struct.error`` or ``UnicodeDecodeError`` for a damaged one)."""
    return [Member(*found) for found in _members(memoryview(data))]


def crc_checked(data: bytes, member: Member) -> None:
    """Raise ValueError where the member's bytes do not have its CRC-32."""
    if zlib.crc32(memoryview(data)[member.start:member.start + member.size]) != member.crc:
        raise ValueError(f"npz member {member.name!r}: bad CRC-32")


@dataclass(frozen=True)
class NpyHeader:
    """What a ``.npy`` member's header says."""

    shape: tuple[int, ...]
    dtype: np.dtype
    fortran: bool
    offset: int  # where the data starts in the archive


def npy_header(data: bytes, member: Member) -> NpyHeader:
    """A member's ``.npy`` header (raises :class:`Unusual` for a header this reader does not
    parse, ValueError for a negative dimension or a member shorter than its shape says)."""
    start = member.start
    head = bytes(data[start:start + 12])
    if head[:6] != _NPY_MAGIC or head[6] not in (1, 2, 3):
        raise Unusual()
    length, skip = (struct.unpack_from("<H", head, 8)[0], 10) if head[6] == 1 else \
        (struct.unpack_from("<I", head, 8)[0], 12)
    if length > NPY_HEADER_MAX:
        raise ValueError(f"npy header of {length} bytes")
    text = bytes(data[start + skip:start + skip + length]).decode("latin1")
    descr, fortran, shape = _DESCR.search(text), _FORTRAN.search(text), _SHAPE.search(text)
    if descr is None or fortran is None or shape is None:
        raise Unusual()
    dtype = np.dtype(descr.group(1))
    dims = tuple(int(d) for d in shape.group(1).split(",") if d.strip())
    if any(d < 0 for d in dims):
        raise ValueError(f"negative dimension in shape {dims}")
    offset = start + skip + length
    if offset + math.prod(dims) * dtype.itemsize > start + member.size:
        raise ValueError(f"npz member {member.name!r} is shorter than its header says")
    return NpyHeader(dims, dtype, fortran.group(1) == "True", offset)


def npy_array(data: bytes, header: NpyHeader) -> np.ndarray:
    """A member's array, of its own (aligned and writable, as ``numpy.load``'s)."""
    array = np.frombuffer(data, header.dtype, math.prod(header.shape), header.offset).copy()
    if header.fortran:
        return array.reshape(header.shape[::-1]).T
    return array.reshape(header.shape)


def read_npz(data: bytes) -> dict[str, np.ndarray]:
    """Every member of an npz archive, by name (``.npy`` dropped), as arrays of their own
    (aligned and writable, as ``numpy.load``'s); object arrays are refused as ``numpy.load``
    refuses them without ``allow_pickle``."""
    try:
        members = stored_members(data)
        headers = [npy_header(data, member) for member in members]
        for member, header in zip(members, headers, strict=True):
            crc_checked(data, member)
            if header.dtype.hasobject:
                raise ValueError("Object arrays cannot be loaded when allow_pickle=False")
        return {member.name.removesuffix(".npy"): npy_array(data, header)
                for member, header in zip(members, headers, strict=True)}
    except Exception:  # noqa: BLE001 - anything unusual or damaged: numpy.load says what
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            return {name: archive[name] for name in archive.files}


def write_npz(arrays: dict) -> bytes:
    """An npz archive of ``arrays`` (name -> array_like) in one piece (:func:`npz_stream`,
    each array a member), which ``numpy.load`` reads as ``numpy.savez``'s; object arrays are
    ``numpy.savez``'s own (pickled: the service refuses them, naming the column)."""
    members = {name: np.asarray(value) for name, value in arrays.items()}
    if any(a.dtype.hasobject for a in members.values()):
        buffer = io.BytesIO()
        np.savez(buffer, **members)
        return buffer.getvalue()
    return b"".join(npz_stream(((name, a.dtype, a.shape, (a,)) for name, a in members.items()),
                               piece_bytes=math.inf))


@lru_cache(maxsize=1024)
def _npy_header(dtype: np.dtype, shape: tuple) -> bytes:
    """A ``.npy`` header (format 1.0, padded to 64 bytes, as numpy writes it)."""
    header = (f"{{'descr': {np.lib.format.dtype_to_descr(dtype)!r}, "
              f"'fortran_order': False, 'shape': {shape!r}, }}")
    padding = 64 - (len(header) + 11) % 64
    header = (header + " " * padding + "\n").encode("latin1")
    return _NPY_MAGIC + b"\x01\x00" + struct.pack("<H", len(header)) + header


def _central(name: bytes, crc: int, size: int, offset: int, flags: int) -> bytes:
    """A member's central directory entry, its size and offset in a zip64 extra field where
    either needs one."""
    big = [v for v in (size, size) if v >= ZIP64_FROM] + ([offset] if offset >= ZIP64_FROM
                                                          else [])
    extra = struct.pack(f"<2H{len(big)}Q", _ZIP64_EXTRA, 8 * len(big), *big) if big else b""
    shown = [min(v, _FULL32) if v < ZIP64_FROM else _FULL32 for v in (size, offset)]
    return _CENTRAL_ENTRY.pack(_CENTRAL, 45, 45 if big else 20, flags, 0, 0, 0x21, crc,
                               shown[0], shown[0], len(name), len(extra), 0, 0, 0, 0,
                               shown[1]) + name + extra


def _end(entries: int, directory: int, offset: int) -> bytes:
    """The end of the archive: a zip64 end record and its locator where the directory's
    place or size needs them, then the end record."""
    out = b""
    if max(directory, offset) >= ZIP64_FROM or entries >= _FULL16:
        at = offset + directory
        out = struct.pack("<4sQ2H2I4Q", _EOCD64, 44, 45, 45, 0, 0, entries, entries,
                          directory, offset)
        out += struct.pack("<4sIQI", _LOCATOR, 0, at, 1)
        entries, directory, offset = min(entries, _FULL16), _FULL32, _FULL32
    return out + struct.pack("<4s4H2IH", _EOCD, 0, 0, entries, entries, directory, offset, 0)


def npz_stream(members: Iterable, piece_bytes: int) -> Iterator[bytes]:
    """An npz archive in pieces of about ``piece_bytes``; ``members`` yields ``(name, dtype,
    shape, slices)``, ``slices`` the member's rows slice after slice (C order, any number).
    Each member's sizes and CRC-32 follow its data (a data descriptor) and are in the
    central directory."""
    pending: list[bytes] = []
    held = written = 0  # bytes waiting in pending; bytes yielded before them
    central = []
    for name, dtype, shape, slices in members:
        dtype, encoded = np.dtype(dtype), f"{name}.npy".encode()
        shape = tuple(int(d) for d in shape)
        header = _npy_header(dtype, shape)
        wide = len(header) + math.prod(shape) * dtype.itemsize >= ZIP64_FROM
        extra = struct.pack("<2H2Q", _ZIP64_EXTRA, 16, 0, 0) if wide else b""
        local = written + held
        head = _LOCAL_ENTRY.pack(_LOCAL, 45 if wide else 20, 8, 0, 0, 0x21, 0, 0, 0,
                                 len(encoded), len(extra)) + encoded + extra
        crc, size = zlib.crc32(header), len(header)
        pending += [head, header]
        held += len(head) + len(header)
        for part in slices:
            data = (part if type(part) is np.ndarray and part.dtype == dtype
                    and part.flags.c_contiguous else np.ascontiguousarray(part, dtype)).tobytes()
            crc, size = zlib.crc32(data, crc), size + len(data)
            pending.append(data)
            held += len(data)
            if held >= piece_bytes:
                yield b"".join(pending)
                written += held
                pending, held = [], 0
        descriptor = struct.pack("<4sI2Q" if wide else "<4s3I", _DESCRIPTOR, crc, size, size)
        pending.append(descriptor)
        held += len(descriptor)
        central.append(_central(encoded, crc, size, local, 8))
    directory = b"".join(central)
    offset = written + held
    pending += [directory, _end(len(central), len(directory), offset)]
    yield b"".join(pending)
