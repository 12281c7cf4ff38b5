"""Compound answers encoded: one row as JSON, a batch as JSON or npz streamed in pieces.

A batch's answer is written a bounded piece at a time, codes turned into names
:data:`STREAM_ROWS` rows at a time, so that encoding holds the compact answer
(:class:`impactnet.service.compound_arrays.CompoundArrays`) plus one piece, never the whole
text or archive:

* JSON: the columnar answer (``n``, ``mode``, ``model_version``, the summary columns, and
  ``contacts`` = {``offsets``, ``part_a``, ...}), each column's values in slices;
* npz: a zip archive written as a stream (each member's header, then its data in slices; the
  sizes go in data descriptors and the central directory), readable by ``numpy.load``. The
  members are the summary columns, ``predictor``, ``mode``, ``model_version``,
  ``contact_offsets`` and ``contact_<name>`` (``contact_type`` for the type).
"""
from __future__ import annotations

import io
import zipfile
from collections.abc import Iterator

import numpy as np
import orjson

from impactnet.service.codecs.answer_encode import PIECE_BYTES, pieces_of
from impactnet.service.compound_arrays import CONTACT_COLUMNS, CONTACT_NAMES, CompoundArrays

#: Rows of one column per encoding step: ~2,048 contacts are ~300 KB of JSON text at most.
STREAM_ROWS = 2048
#: The summary columns, in the answer's order.
SUMMARY = ("colliding", "point", "normal", "depth", "cluster_size")
#: Contact columns whose codes are written as names, and their tables.
_NAMED = {"part_a": "part_names", "part_b": "part_names", "contact_type": None}


def _table(arrays: CompoundArrays, name: str) -> np.ndarray | None:
    """The names of a coded contact column (None: the column holds numbers)."""
    if name not in _NAMED:
        return None
    return CONTACT_NAMES if _NAMED[name] is None else arrays.part_names


def _slices(values: np.ndarray, names: np.ndarray | None) -> Iterator[np.ndarray]:
    """``values`` in slices of :data:`STREAM_ROWS` rows, codes turned into names."""
    for start in range(0, len(values), STREAM_ROWS):
        part = values[start:start + STREAM_ROWS]
        yield part if names is None else names[part]


def _columns(arrays: CompoundArrays):
    """(path, values, names) of every column of the answer, in order."""
    yield "predictor", arrays.predictor, arrays.predictor_names
    for name in SUMMARY:
        yield name, getattr(arrays, name), None
    yield "contacts.offsets", arrays.offsets, None
    for name, _, _ in CONTACT_COLUMNS:
        yield f"contacts.{name}", arrays.contacts[name], _table(arrays, name)


def _texts(values: np.ndarray, names: np.ndarray | None) -> Iterator[bytes]:
    for part in _slices(values, names):
        yield (orjson.dumps(part, option=orjson.OPT_SERIALIZE_NUMPY) if names is None
               else orjson.dumps(part.tolist()))[1:-1]


def json_pieces(arrays: CompoundArrays, mode: str, model_version: str) -> Iterator[bytes]:
    """The columnar JSON answer in pieces of about :data:`PIECE_BYTES`."""
    head = b'{"n":%d,"mode":%s,"model_version":%s' % (len(arrays), orjson.dumps(mode),
                                                        orjson.dumps(model_version))
    columns = ((b',"contacts":{' if path == "contacts.offsets" else b",")
               + b'"%s":' % path.rsplit(".", 1)[-1].encode() for path, _, _ in _columns(arrays))
    texts = (_texts(values, names) for _, values, names in _columns(arrays))
    return pieces_of(head, zip(columns, texts), b"}}")


def encode_json(arrays: CompoundArrays, mode: str, model_version: str) -> bytes:
    """The whole JSON answer at once (small answers)."""
    return b"".join(json_pieces(arrays, mode, model_version))


class _Sink(io.RawIOBase):
    """A write-only, unseekable file that keeps what was written until :meth:`take`."""

    def __init__(self) -> None:
        self._chunks: list[bytes] = []
        self._position = 0

    def writable(self) -> bool:
        return True

    def write(self, data) -> int:
        self._chunks.append(bytes(data))
        self._position += len(data)
        return len(data)

    def tell(self) -> int:
        return self._position

    @property
    def pending(self) -> int:
        """Bytes written and not taken yet."""
        return sum(len(c) for c in self._chunks)

    def take(self) -> bytes:
        out, self._chunks = b"".join(self._chunks), []
        return out


def _npz_members(arrays: CompoundArrays, mode: str, model_version: str):
    """(member name, dtype, shape, slices) of the npz answer."""
    yield "mode", np.dtype(f"<U{len(mode)}"), (), iter([np.asarray(mode)])
    yield "model_version", np.dtype(f"<U{max(1, len(model_version))}"), (), iter(
        [np.asarray(model_version)])
    for path, values, names in _columns(arrays):
        member = path.replace("contacts.", "contact_").replace("contact_contact_", "contact_")
        dtype = values.dtype if names is None else np.dtype(
            f"<U{max(1, max((len(s) for s in names.tolist()), default=1))}")
        if path == "predictor":
            dtype = np.dtype("<U10")
        elif path in ("contacts.feature_a", "contacts.feature_b"):
            dtype = np.dtype(np.int64)
        yield member, dtype, values.shape, _slices(values, names)


def npz_pieces(arrays: CompoundArrays, mode: str, model_version: str) -> Iterator[bytes]:
    """The npz answer (module docstring) in pieces of about :data:`PIECE_BYTES`."""
    sink = _Sink()
    with zipfile.ZipFile(sink, mode="w", compression=zipfile.ZIP_STORED,
                         allowZip64=True) as archive:
        for member, dtype, shape, slices in _npz_members(arrays, mode, model_version):
            with archive.open(f"{member}.npy", "w", force_zip64=True) as out:
                np.lib.format.write_array_header_2_0(out, {
                    "descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False,
                    "shape": tuple(shape)})
                for part in slices:
                    out.write(np.ascontiguousarray(part, dtype=dtype).tobytes())
                    if sink.pending >= PIECE_BYTES:
                        yield sink.take()
            yield sink.take()
    yield sink.take()


def encode_npz(arrays: CompoundArrays, mode: str, model_version: str) -> bytes:
    """The whole npz answer at once (small answers)."""
    return b"".join(npz_pieces(arrays, mode, model_version))


def row_json(arrays: CompoundArrays, i: int) -> dict:
    """Row i as the single-pair answer's fields (summary and its ``contacts`` list)."""
    rows = slice(int(arrays.offsets[i]), int(arrays.offsets[i + 1]))
    columns = {}
    for name, _, _ in CONTACT_COLUMNS:
        values = arrays.contacts[name][rows]
        names = _table(arrays, name)
        columns[name] = (values if names is None else names[values]).tolist()
    contacts = [dict(zip(columns, values, strict=True))
                for values in zip(*columns.values(), strict=True)]
    return {"colliding": bool(arrays.colliding[i]), "point": arrays.point[i].tolist(),
            "normal": arrays.normal[i].tolist(), "depth": float(arrays.depth[i]),
            "cluster_size": int(arrays.cluster_size[i]),
            "predictor": str(arrays.predictor_names[arrays.predictor[i]]),
            "contacts": contacts}
