"""Pure ASGI middleware (no BaseHTTPMiddleware: it costs a task per request).

Order, outermost first:

1. :class:`RequestContext`: request id (``X-Request-ID`` honoured and returned), one JSON
   access-log line, the request / latency metrics, and the catch-all: an exception that escapes
   the app is logged with its traceback and answered with a JSON 500 (the only 500 there is).
2. :class:`BodyLimit`: 413 before the app runs when ``Content-Length`` exceeds the limit, and
   while the body streams in (counting the bytes of ``http.request`` messages) when it is
   chunked or lies; the body is never read whole first.
3. :class:`ConcurrencyLimit`: at most ``max_concurrency`` ``/v1`` requests in flight; more get
   503 with ``Retry-After`` at once (probes and /metrics are never limited).
"""
from __future__ import annotations

import logging
import time

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.errors import PayloadTooLarge, error_body
from service.logging import request_id_from, request_id_var
from service.runtime import Runtime

log = logging.getLogger("impactnet.service")
access = logging.getLogger("impactnet.access")

_JSON_HEADERS = [(b"content-type", b"application/json")]


async def send_error(send: Send, status: int, error: str, message: str,
                     headers: list[tuple[bytes, bytes]] | None = None) -> None:
    body = error_body(status, error, message)
    await send({"type": "http.response.start", "status": status,
                "headers": _JSON_HEADERS + [(b"content-length", str(len(body)).encode())]
                + (headers or [])})
    await send({"type": "http.response.body", "body": body})


def _header(scope: Scope, name: bytes) -> bytes | None:
    for key, value in scope["headers"]:
        if key == name:
            return value
    return None


class RequestContext:
    def __init__(self, app: ASGIApp, runtime: Runtime) -> None:
        self.app, self.runtime = app, runtime

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        rid = request_id_from(_header(scope, b"x-request-id"))
        token = request_id_var.set(rid)
        rid_header = (b"x-request-id", rid.encode())
        status, response_started = 500, False

        async def send_with_id(message: Message) -> None:
            nonlocal status, response_started
            if message["type"] == "http.response.start":
                response_started, status = True, message["status"]
                message = {**message, "headers": [*message.get("headers", ()), rid_header]}
            await send(message)

        try:
            await self.app(scope, receive, send_with_id)
        except Exception:  # noqa: BLE001 - the catch-all: a bug, never an input fault
            log.exception("unhandled error", extra={"path": scope.get("path")})
            if not response_started:
                await send_error(send_with_id, 500, "internal_error", "internal error (a "
                                 "bug); quote the request id when reporting it")
        finally:
            self._record(scope, status, time.perf_counter() - started)
            request_id_var.reset(token)

    def _record(self, scope: Scope, status: int, seconds: float) -> None:
        route = scope.get("route")
        template = getattr(route, "path", None) or "<unmatched>"
        method = scope.get("method", "")
        metrics = self.runtime.metrics
        metrics.requests.labels(template, method, str(status)).inc()
        metrics.latency.labels(template, method).observe(seconds)
        if self.runtime.settings.access_log:
            access.info("request", extra={"method": method, "path": scope.get("path"),
                                          "status": status, "ms": round(seconds * 1e3, 3)})


class BodyLimit:
    def __init__(self, app: ASGIApp, runtime: Runtime) -> None:
        self.app, self.runtime = app, runtime

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.runtime.settings.max_body_bytes
        message = f"request body larger than the limit of {limit} bytes"
        declared = _header(scope, b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            self.runtime.metrics.rejected.labels("body_too_large").inc()
            await send_error(send, 413, "body_too_large", message, [(b"connection", b"close")])
            return
        received = 0
        response_started = False

        async def counting_receive() -> Message:
            nonlocal received
            msg = await receive()
            if msg["type"] == "http.request":
                received += len(msg.get("body", b""))
                if received > limit:
                    self.runtime.metrics.rejected.labels("body_too_large").inc()
                    raise PayloadTooLarge("body_too_large", message)
            return msg

        async def tracking_send(msg: Message) -> None:
            nonlocal response_started
            if msg["type"] == "http.response.start":
                response_started = True
            await send(msg)

        try:
            await self.app(scope, counting_receive, tracking_send)
        except PayloadTooLarge:  # raised by counting_receive where no handler caught it
            if response_started:
                raise
            await send_error(send, 413, "body_too_large", message, [(b"connection", b"close")])


class ConcurrencyLimit:
    def __init__(self, app: ASGIApp, runtime: Runtime) -> None:
        self.app, self.runtime = app, runtime
        self.in_flight = 0  # one event loop: no lock needed

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not scope["path"].startswith("/v1/"):
            await self.app(scope, receive, send)
            return
        settings, metrics = self.runtime.settings, self.runtime.metrics
        if self.in_flight >= settings.max_concurrency:
            metrics.rejected.labels("overloaded").inc()
            await send_error(send, 503, "overloaded",
                             f"more than {settings.max_concurrency} requests in flight; retry",
                             [(b"retry-after", str(settings.retry_after_s).encode())])
            return
        self.in_flight += 1
        metrics.in_flight.inc()
        try:
            await self.app(scope, receive, send)
        finally:
            self.in_flight -= 1
            metrics.in_flight.dec()
