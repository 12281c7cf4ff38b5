"""Request bodies, read in full before a request is computed: a deadline, a size cap, memory.

:class:`BodyReader` (pure ASGI middleware) reads the body of every request that has one before
the application sees the request, so that a request still uploading holds no compute slot
(:class:`impactnet.service.api.middleware.ConcurrencyLimit` sits inside it) and nothing of the
application's:

* **cap**: the body may not exceed the limit of its route (:func:`body_limit`): 413 when
  ``Content-Length`` says so, before anything is stored, and as soon as a streamed body passes
  it. The 413 is sent at once; a client that sends its whole body before it reads (most HTTP
  libraries) would then see its connection reset instead of the 413, so the rest of the body
  is read and dropped before the answer ends and the connection closes, up to
  :data:`DISCARD_MAX_BYTES` and within the body deadline, as nginx's lingering close does (a
  client that asked ``Expect: 100-continue`` sends nothing more: nothing is read);
* **deadline**: the whole body must have arrived within ``body_timeout_s``; otherwise 408
  ``body_timeout``, and the connection is closed (a stalled client sent headers and a byte, then
  nothing: it must not hold anything for longer; :mod:`impactnet.service.limits.uploads` keeps the
  deadlines). When the server shuts down, every upload still in progress ends at once with 503
  ``not_ready``, so that a stalled client cannot delay the exit;
* **memory**: every chunk is reserved in the request's
:class:`impactnet.service.limits.budget.Lease` as it
  arrives; no room: 503 ``overloaded`` with Retry-After. The lease is released when the
  request has been answered.

The application then receives the body as one message (``receive`` replays it; later calls go
to the server, which reports a disconnect), and finds the lease at ``scope[LEASE]``.
"""
from __future__ import annotations

import asyncio
import time

from starlette.types import Message, Receive, Scope, Send

from impactnet.service.errors import Overloaded, PayloadTooLarge
from impactnet.service.limits.budget import Lease
from impactnet.service.respond import Middleware, header, send_error
from impactnet.service.runtime import Runtime

#: Key of the request's memory lease in the ASGI scope.
LEASE = "impactnet.lease"
NPZ = b"application/x-npz"
#: Routes whose bodies may be large (a batch, a frame): JSON up to ``max_json_body_bytes``,
#: npz up to ``max_body_bytes``.
LARGE_BODY_PATHS = ("/v2/contact/batch", "/v2/frame", "/v2/worlds")
_CLOSE = [(b"connection", b"close")]
#: Most bytes of an oversized body read and dropped before its 413 is sent (more: the
#: connection is closed after the 413 without reading on): the largest body any route takes.
DISCARD_MAX_BYTES = 64 << 20
#: Seconds without a byte of an oversized body after which the reading stops and the
#: connection closes (a client that sends its body keeps sending; a stalled one is let go).
DISCARD_IDLE_S = 1.0


def body_limit(scope: Scope, runtime: Runtime) -> int:
    """Bytes the body of this request may have: ``max_body_bytes`` for every body, and less
    for a JSON batch (``max_json_body_bytes``) and for any other request
    (``max_pair_body_bytes``)."""
    settings = runtime.settings
    if scope["path"] not in LARGE_BODY_PATHS:
        return min(settings.max_body_bytes, settings.max_pair_body_bytes)
    media = (header(scope, b"content-type") or b"").split(b";", 1)[0].strip().lower()
    if media == NPZ:
        return settings.max_body_bytes
    return min(settings.max_body_bytes, settings.max_json_body_bytes)


def _has_body(scope: Scope, length: bytes | None) -> bool:
    """Whether to read a body: declared (``length``: the Content-Length header), or possible
    (any method but GET and HEAD; an ASGI server other than uvicorn may stream a body
    without either header)."""
    if length is not None:
        return length != b"0"
    return (header(scope, b"transfer-encoding") is not None
            or scope.get("method") not in ("GET", "HEAD"))


class BodyReader(Middleware):
    """Read the whole body first (module docstring), then call the application."""

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        lease = scope[LEASE] = Lease(self.runtime.budget)
        started = time.monotonic()
        try:
            declared = header(scope, b"content-length")
            if not _has_body(scope, declared):
                await self.app(scope, receive, send)
                return
            limit = body_limit(scope, self.runtime)
            if declared is not None and declared.isdigit() and int(declared) > limit:
                continues = (header(scope, b"expect") or b"").lower() == b"100-continue"
                await self._too_large(send, limit, None if continues else (receive, 0,
                                                                           int(declared)))
                return
            body = await self._read(receive, send, limit, lease)
            if body is None:  # answered already (408, 413, 503) or the client left
                return
            replayed = False

            async def replay() -> Message:
                nonlocal replayed
                if replayed:
                    return await receive()
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}

            await self.app(scope, replay, send)
        finally:
            lease.release()
            self.runtime.trimmer.released(lease.peak, time.monotonic() - started)

    async def _too_large(self, send: Send, limit: int, rest=None) -> None:
        """The 413; with ``rest`` (receive, bytes read, bytes declared or None), the rest of
        the body is then read and dropped before the answer ends (:meth:`_discard`)."""
        self.runtime.metrics.rejected.labels("body_too_large").inc()
        await send_error(send, 413, "body_too_large",
                         f"request body larger than the limit of {limit} bytes", _CLOSE,
                         more_body=rest is not None)
        if rest is not None:
            try:
                await self._discard(*rest)
            finally:
                await send({"type": "http.response.body", "body": b"", "more_body": False})

    async def _read(self, receive: Receive, send: Send, limit: int, lease: Lease) -> bytes | None:
        """The body, or None after answering the error (or when the client disconnected)."""
        uploads = self.runtime.uploads
        chunks: list[bytes] = []
        total = 0
        task = uploads.begin()
        try:
            more = True
            while more:
                message = await receive()
                if message["type"] == "http.disconnect":
                    return None
                chunk = message.get("body", b"")
                more = message.get("more_body", False)
                if not chunk:
                    continue
                total += len(chunk)
                if total > limit:
                    await self._too_large(send, limit, (receive, total, None) if more else None)
                    return None
                await lease.areserve(len(chunk), "the request body")
                chunks.append(chunk)
        except asyncio.CancelledError:
            if not uploads.expired(task):
                raise
            await self._timed_out(send, uploads.shutting_down)
            return None
        except (Overloaded, PayloadTooLarge) as exc:
            await self._refused(send, exc)
            return None
        finally:
            uploads.end(task)
        if len(chunks) == 1:  # a small body: one message
            return chunks[0]
        return await self._joined(chunks, total, lease, send)

    async def _discard(self, receive: Receive, read: int, declared: int | None) -> None:
        """Read and drop the rest of an oversized body (``read`` bytes of it read already,
        ``declared`` in all if known), up to :data:`DISCARD_MAX_BYTES`, within the body
        deadline, and while it keeps coming (a pause of :data:`DISCARD_IDLE_S` ends it, as
        nginx's ``lingering_timeout``), so that a client still sending it reads the 413."""
        if declared is not None and declared > DISCARD_MAX_BYTES:
            return
        uploads = self.runtime.uploads
        task = uploads.begin()
        try:
            more = True
            while more and read <= DISCARD_MAX_BYTES:
                message = await asyncio.wait_for(receive(), DISCARD_IDLE_S)
                if message["type"] == "http.disconnect":
                    return
                read += len(message.get("body", b""))
                more = message.get("more_body", False)
        except TimeoutError:
            return
        except asyncio.CancelledError:
            if not uploads.expired(task):
                raise
        finally:
            uploads.end(task)

    async def _refused(self, send: Send, exc: Overloaded | PayloadTooLarge) -> None:
        extra = [(b"retry-after", v.encode()) for k, v in (exc.headers or {}).items()
                 if k.lower() == "retry-after"]
        await send_error(send, exc.status_code, exc.error, exc.message, _CLOSE + extra)

    async def _joined(self, chunks: list[bytes], total: int, lease: Lease,
                      send: Send) -> bytes | None:
        """One bytes object; the join's temporary copy is counted while it exists."""
        if not chunks:
            return b""
        try:
            await lease.areserve(total, "joining the request body")
        except Overloaded as exc:
            await self._refused(send, exc)
            return None
        try:
            return b"".join(chunks)
        finally:
            chunks.clear()
            lease.give_back(total)

    async def _timed_out(self, send: Send, shutting_down: bool) -> None:
        settings = self.runtime.settings
        if shutting_down:
            await send_error(send, 503, "not_ready", "the server is shutting down; the request "
                             "body had not arrived", _CLOSE)
            return
        self.runtime.metrics.rejected.labels("body_timeout").inc()
        await send_error(send, 408, "body_timeout", "the request body did not arrive within "
                         f"{settings.body_timeout_s:g} s", _CLOSE)
