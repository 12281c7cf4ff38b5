"""npz batch bodies: every member's header is read and checked before anything is decompressed.

A few kilobytes of deflated zeros can declare millions of rows (a 66 KB archive once held
5.1 million rows of int8 columns, which became ~560 MB of float64). So, in this order:

1. the archive may hold at most :data:`MAX_MEMBERS` members, counted by their central-directory
   signatures before the zip directory is parsed (a directory of millions of entries would
   cost more than the body itself);
2. the members' declared sizes may not expand beyond ``max_body_bytes`` (413);
3. each member's ``.npy`` header (magic, shape, dtype: the first bytes, nothing more is
   inflated) must name a known column (422), hold no Python objects (422, no pickle), be no
   shorter than its shape says (422), and have at most ``max_pairs`` rows (413);
4. the decoded size (the members as stored plus their float64 copies) is reserved in the
   request's memory lease (503 when there is no room);

and only then are the members decompressed and read, with ``allow_pickle=False``. An archive
of stored members (what ``numpy.savez`` and the client write) is walked in one pass over the
body (:mod:`impactnet.service.codecs.npz_format`, each member's CRC-32 checked with its
header); any other goes through ``zipfile``, the same checks in the same order.
"""
from __future__ import annotations

import functools
import io
import math
import zipfile
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from impactnet.service.codecs import npz_format as nf
from impactnet.service.codecs import scan
from impactnet.service.codecs.columns import COLUMNS, tail_of, too_many_pairs, unknown_column
from impactnet.service.errors import InputError, Overloaded, PayloadTooLarge
from impactnet.service.limits.budget import Lease, NeedMemory

#: Most members an npz body may hold: a batch has at most 6 columns per side, 12 in all; a
#: frame 9.
MAX_MEMBERS = 16
#: Signature of a zip central-directory entry: every member the zip reader lists has one
#: (a count of them in the body is never below the number of members).
_CENTRAL_DIRECTORY = b"PK\x01\x02"
#: Largest .npy header in bytes that is read (np.save writes ~128).
_NPY_HEADER_MAX = 10_000
#: Bytes of a float64, the dtype every numeric column is converted to.
FLOAT64_BYTES = 8


def _header(archive: zipfile.ZipFile, member: zipfile.ZipInfo) -> tuple[tuple, np.dtype]:
    """Shape and dtype from a member's .npy header (only its first bytes are inflated)."""
    with archive.open(member) as f:
        version = np.lib.format.read_magic(f)
        if version not in ((1, 0), (2, 0)):
            raise ValueError(f"npy format version {version} (use 1.0 or 2.0)")
        read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                else np.lib.format.read_array_header_2_0)
        shape, _, dtype = read(f, max_header_size=_NPY_HEADER_MAX)
    return shape, dtype


@dataclass(frozen=True)
class _Entry:
    """A member as the checks see it, from the one-pass reader or from ``zipfile``."""

    name: str  # its file name
    size: int  # its bytes, uncompressed
    header: Callable  # () -> (shape, dtype), read when the checks reach it
    array: Callable  # () -> the member's array, read once every check has passed


def _stored_entries(body: bytes) -> list[_Entry]:
    """The members of an archive of stored members, read in one pass
    (:mod:`impactnet.service.codecs.npz_format`; raises ``Unusual`` for another archive):
    each member's CRC-32 checked and its header read when the checks reach it, once."""
    entries = []
    for member in nf.stored_members(body):
        @functools.cache
        def header(member=member) -> nf.NpyHeader:
            nf.crc_checked(body, member)
            return nf.npy_header(body, member)

        entries.append(_Entry(member.name, member.size,
                              lambda header=header: (header().shape, header().dtype),
                              lambda header=header: nf.npy_array(body, header())))
    return entries


def _zip_entries(body: bytes) -> list[_Entry]:
    """The members of any other archive (compressed members), through ``zipfile``."""
    archive = zipfile.ZipFile(io.BytesIO(body))

    def array(member):
        with archive.open(member) as f:
            return np.lib.format.read_array(f, allow_pickle=False,
                                            max_header_size=_NPY_HEADER_MAX)

    return [_Entry(m.filename, m.file_size, lambda m=m: _header(archive, m),
                   lambda m=m: array(m)) for m in archive.infolist()]


@dataclass(frozen=True)
class Layout:
    """What an npz body may hold: its columns, a row's shape in each, the 413 past the cap."""

    columns: tuple[str, ...]  # the known column names
    tail: Callable  # column -> a row's trailing shape (None: names, one per row)
    too_many: Callable  # (rows, cap) -> the 413 error
    unknown: Callable  # column -> the 422 error


#: A batch's layout (the pairs' columns).
BATCH = Layout(COLUMNS, tail_of, too_many_pairs, unknown_column)


def _rows(column: str, shape: tuple, layout: Layout) -> int:
    """Rows a member of this shape holds (1 for a broadcast value)."""
    tail = layout.tail(column)
    per_pair_ndim = 1 if tail is None else len(tail) + 1
    return int(shape[0]) if len(shape) == per_pair_ndim else 1


def _checked(entries: list[_Entry], max_pairs: int, layout: Layout) -> tuple[list, int]:
    """Members with their column names, and their decoded size in bytes (step 3)."""
    members, decoded = [], 0
    for entry in entries:
        name = entry.name
        column = name[:-4]
        if not name.endswith(".npy") or any(column == c for _, c in members):
            raise InputError("body", f"npz member {name!r}: expected one <column>.npy per "
                             "column", type_="npz_invalid")
        if column not in layout.columns:
            raise layout.unknown(column)
        shape, dtype = entry.header()
        if dtype.hasobject:
            raise InputError(column, "object arrays are not accepted (no pickle)",
                             type_="npz_invalid")
        count = math.prod(shape)
        if count * dtype.itemsize > entry.size:
            raise ValueError(f"member {name!r} is shorter than its header says")
        rows = _rows(column, shape, layout)
        if rows > max_pairs:
            raise layout.too_many(rows, max_pairs)
        copy = 0 if layout.tail(column) is None else count * FLOAT64_BYTES
        decoded += entry.size + copy
        members.append((entry, column))
    return members, decoded


def parse_npz(body: bytes, max_bytes: int, max_pairs: int, lease: Lease,
              layout: Layout = BATCH) -> dict:
    """Columns of an npz body of ``layout`` (module docstring for the checks made first).

    Raises InputError (422), PayloadTooLarge (413) and Overloaded (503).
    """
    if scan.count(body, _CENTRAL_DIRECTORY) > MAX_MEMBERS:
        raise InputError("body", f"npz with more than {MAX_MEMBERS} members; a batch has at "
                         "most 12 columns, a frame 9", type_="npz_invalid")
    try:
        try:
            entries = _stored_entries(body)
        except nf.Unusual:
            entries = _zip_entries(body)
        if sum(e.size for e in entries) > max_bytes:
            raise PayloadTooLarge("body_too_large", f"npz body expands beyond the limit of "
                                  f"{max_bytes} bytes")
        members, decoded = _checked(entries, max_pairs, layout)
        lease.reserve(decoded, "decoding the npz body")
        return {column: entry.array() for entry, column in members}
    except (InputError, PayloadTooLarge, Overloaded, NeedMemory):
        raise
    except Exception as exc:  # noqa: BLE001 - any fault of untrusted bytes is a bad body
        raise InputError("body", f"malformed npz: {type(exc).__name__}: {exc}",
                         type_="npz_invalid") from exc
