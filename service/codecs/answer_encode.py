"""Batch answers encoded: npz at once, JSON in bounded pieces, streamed to the client.

The JSON answer of a large batch is much larger than its arrays (a 100,000-pair answer with
the manifold and the paper's angles is 26.9 MB of text from 36 MB of arrays) and encoding it
whole cost 4 times its size at the peak (orjson's growing buffer and its final copy). So it is
written :data:`STREAM_ROWS` rows of one column at a time (orjson, shortest round-trip floats,
the same bytes as one call over the whole answer), grouped into pieces of about
:data:`PIECE_BYTES`, each encoded in a worker thread and sent before the next is made
(:class:`StreamedAnswer`): the answer's memory is its arrays plus one piece. A client that does
not take the answer within ``send_timeout_s`` is disconnected.
"""
from __future__ import annotations

import asyncio
import io
import logging
from collections.abc import Iterator

import numpy as np
import orjson
from starlette.concurrency import run_in_threadpool
from starlette.responses import Response
from starlette.types import Receive, Scope, Send

from impactnet.models.contacts import CONTACT_TYPES

log = logging.getLogger("impactnet.service")

#: Rows of one column per orjson call: 2,048 rows of the widest column (8x3 manifold points)
#: are ~0.9 MB of text and ~3 ms of encoding, which the event loop may wait for (the GIL).
STREAM_ROWS = 2048
#: Bytes of text gathered into one piece (one thread hop, one send).
PIECE_BYTES = 1 << 20
CONTACT_NAMES = np.asarray(CONTACT_TYPES)
#: Answer arrays that the JSON answer writes as names instead.
_CODES = ("predictor_code", "predictor_names", "contact_type_code")


def _columns(arrays: dict) -> Iterator[tuple[str, np.ndarray]]:
    """The JSON answer's columns in order: names first, then the arrays as they come."""
    yield "predictor", (arrays["predictor_names"], arrays["predictor_code"])
    yield "contact_type", (CONTACT_NAMES, arrays["contact_type_code"])
    for key, values in arrays.items():
        if key not in _CODES:
            yield key, values


def _text(values, start: int, stop: int) -> bytes:
    """``start:stop`` of a column as JSON text without the enclosing brackets."""
    if isinstance(values, tuple):  # (names, codes)
        names, codes = values
        return orjson.dumps(names[codes[start:stop]].tolist())[1:-1]
    return orjson.dumps(values[start:stop], option=orjson.OPT_SERIALIZE_NUMPY)[1:-1]


def pieces_of(head: bytes, columns, tail: bytes) -> Iterator[bytes]:
    """``head``, then each column as ``opening + "[" + its texts joined by "," + "]"``, then
    ``tail``, gathered into pieces of about :data:`PIECE_BYTES`; ``columns`` yields
    ``(opening, texts)`` (each text a slice of values as JSON without its brackets)."""
    buffer, size = [head], 0
    for opening, texts in columns:
        buffer.append(opening + b"[")
        first = True
        for text in texts:
            if text:
                buffer.append(text if first else b"," + text)
                first = False
            size += len(text)
            if size >= PIECE_BYTES:
                yield b"".join(buffer)
                buffer, size = [], 0
        buffer.append(b"]")
    buffer.append(tail)
    yield b"".join(buffer)


def json_pieces(arrays: dict, mode: str, model_version: str) -> Iterator[bytes]:
    """The JSON answer (:class:`impactnet.service.api.schemas.BatchResponse`) in pieces of
    ~PIECE_BYTES."""
    n = len(arrays["depth"])
    head = b'{"n":%d,"mode":%s,"model_version":%s' % (n, orjson.dumps(mode),
                                                        orjson.dumps(model_version))
    columns = ((b',"%s":' % key.encode(),
                (_text(values, start, start + STREAM_ROWS) for start in range(0, n, STREAM_ROWS)))
               for key, values in _columns(arrays))
    return pieces_of(head, columns, b"}")


def encode_json(arrays: dict, mode: str, model_version: str) -> bytes:
    """The whole JSON answer at once (small batches)."""
    return b"".join(json_pieces(arrays, mode, model_version))


def encode_npz(arrays: dict, mode: str, model_version: str) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, mode=np.array(mode), model_version=np.array(model_version),
             contact_type_names=CONTACT_NAMES, **arrays)
    return buffer.getvalue()


class StreamedAnswer(Response):
    """A 200 answer (JSON or npz) sent piece by piece (chunked), each piece made in a worker
    thread."""

    def __init__(self, pieces: Iterator[bytes], headers: dict[str, str],
                 send_timeout_s: float, media_type: str = "application/json") -> None:
        self.status_code, self.background = 200, None
        self.media_type = media_type
        self.init_headers(headers)  # no body yet, so no Content-Length: chunked
        self.pieces, self.send_timeout_s = pieces, send_timeout_s

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        await send({"type": "http.response.start", "status": self.status_code,
                    "headers": self.raw_headers})
        try:
            async with asyncio.timeout(self.send_timeout_s):
                while (piece := await run_in_threadpool(next, self.pieces, None)) is not None:
                    await send({"type": "http.response.body", "body": piece,
                                "more_body": True})
                await send({"type": "http.response.body", "body": b"", "more_body": False})
        except TimeoutError:  # the server closes the connection: the answer is incomplete
            log.warning("answer not taken in time: connection closed",
                        extra={"send_timeout_s": self.send_timeout_s})
