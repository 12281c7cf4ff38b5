"""Answers sent as a stream: JSON text and npz archives made a bounded piece at a time.

A large answer's text is much larger than its arrays, so it is written a slice of rows at a
time and gathered into pieces of about :data:`PIECE_BYTES`, each encoded in a worker thread and
sent before the next is made (:class:`StreamedAnswer`): the answer's memory is its arrays plus
one piece. An npz archive is written the same way (each member's header, then its data in
slices; sizes in data descriptors and the central directory), and ``numpy.load`` reads it. A
client that does not take the answer within ``send_timeout_s`` is disconnected.
"""
from __future__ import annotations

import asyncio
import logging
from collections.abc import Iterable, Iterator

from starlette.concurrency import run_in_threadpool
from starlette.responses import Response
from starlette.types import Receive, Scope, Send

from impactnet.service.codecs.npz_format import npz_stream

log = logging.getLogger("impactnet.service")

#: Bytes of text gathered into one piece (one thread hop, one send).
PIECE_BYTES = 1 << 20
#: Answers of up to this many rows and part contacts together are encoded at once (in a worker
#: thread) and sent with their length; larger ones are streamed.
WHOLE_ROWS = 16_384


def json_pieces(head: bytes, columns: Iterable, tail: bytes) -> Iterator[bytes]:
    """``head``, then each column as ``opening + "[" + texts joined by "," + "]" + closing``,
    then ``tail``, in pieces of about :data:`PIECE_BYTES`; ``columns`` yields
    ``(opening, texts, closing)``, each text a slice of values as JSON without brackets."""
    buffer, size = [head], 0
    for opening, texts, closing in columns:
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
        buffer.append(b"]" + closing)
    buffer.append(tail)
    yield b"".join(buffer)


def npz_pieces(members: Iterable) -> Iterator[bytes]:
    """An npz archive in pieces of about :data:`PIECE_BYTES`; ``members`` yields ``(name,
    dtype, shape, slices)`` with ``slices`` the member's rows, slice after slice
    (:func:`impactnet.service.codecs.npz_format.npz_stream`)."""
    return npz_stream(members, PIECE_BYTES)


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


async def answer_response(work, pieces: Iterator[bytes], answers, headers: dict[str, str],
                          send_timeout_s: float, media_type: str) -> Response:
    """The encoded ``pieces`` of ``answers`` (:class:`~impactnet.models.dispatch.Answers`):
    encoded whole in one worker thread (under the request's ``work`` limit) where their rows
    and part contacts number at most :data:`WHOLE_ROWS`, else streamed piece by piece."""
    rows = len(answers) + len(answers.contacts["depth"])
    if rows <= WHOLE_ROWS:
        whole = await work.run(rows, b"".join, pieces)
        return Response(whole, media_type=media_type, headers=headers)
    return StreamedAnswer(pieces, headers, send_timeout_s, media_type)
