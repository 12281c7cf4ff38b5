"""Pure ASGI middleware (no BaseHTTPMiddleware: it costs a task per request).

Order, outermost first:

1. :class:`RequestContext`: request id (``X-Request-ID`` honoured and returned), the
   replica's name (``X-Replica``, on every answer, errors included), one JSON
   access-log line, the request / latency metrics, ``Connection: close`` on every answer
   while the server drains (keep-alive clients reconnect elsewhere before the socket closes),
   and the catch-all: an exception that escapes the app is logged with its traceback and
   answered with a JSON 500 (the only 500 there is).
2. :class:`impactnet.service.limits.body.BodyReader`: the whole body is read first, under its
route's size
   cap, the body deadline (408) and the memory budget (see there).
3. :class:`ConcurrencyLimit`: at most ``max_concurrency`` ``/v1`` requests being computed,
   from the arrival of their whole body to the start of their answer; more get 503 with
   ``Retry-After`` at once (probes and /metrics are never limited). Refusals feed the
   saturation that /readyz reports (:mod:`impactnet.service.limits.saturation`).
"""
from __future__ import annotations

import logging
import time

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from impactnet.service.log_setup import request_id_from, request_id_var
from impactnet.service.respond import Middleware, header, send_error
from impactnet.service.runtime import Runtime

log = logging.getLogger("impactnet.service")
access = logging.getLogger("impactnet.access")

_CLOSE = (b"connection", b"close")
#: Routes whose answers may be large and streamed: their compute slot is freed when the answer
#: starts.
_STREAMED = ("/v2/contact/batch", "/v2/frame")


class RequestContext(Middleware):
    def __init__(self, app: ASGIApp, runtime: Runtime) -> None:
        super().__init__(app, runtime)
        self._cache: dict[tuple[str, str, int], tuple] = {}
        self._replica = (b"x-replica", runtime.replica.encode("ascii"))

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = time.perf_counter()
        rid = request_id_from(header(scope, b"x-request-id"))
        token = request_id_var.set(rid)
        rid_header = (b"x-request-id", rid.encode())
        status, response_started = 500, False

        async def send_with_id(message: Message) -> None:
            nonlocal status, response_started
            if message["type"] == "http.response.start":
                response_started, status = True, message["status"]
                headers = [*message.get("headers", ()), rid_header, self._replica]
                if self.runtime.draining and _CLOSE not in headers:
                    headers.append(_CLOSE)
                message = {**message, "headers": headers}
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

    def _series(self, template: str, method: str, status: int):
        """The request counter and latency histogram of one (route, method, status), looked
        up once: ``labels()`` costs ~3 us a call, on every request. Routes are templates and
        unknown paths one "<unmatched>", so the cache stays small."""
        key = (template, method, status)
        series = self._cache.get(key)
        if series is None:
            metrics = self.runtime.metrics
            series = self._cache[key] = (metrics.requests.labels(template, method, str(status)),
                                         metrics.latency.labels(template, method))
        return series

    def _record(self, scope: Scope, status: int, seconds: float) -> None:
        route = scope.get("route")
        template = getattr(route, "path", None) or "<unmatched>"
        method = scope.get("method", "")
        requests, latency = self._series(template, method, status)
        requests.inc()
        latency.observe(seconds)
        if self.runtime.settings.access_log:
            access.info("request", extra={"method": method, "path": scope.get("path"),
                                          "status": status, "ms": round(seconds * 1e3, 3)})


class ConcurrencyLimit(Middleware):
    def __init__(self, app: ASGIApp, runtime: Runtime) -> None:
        super().__init__(app, runtime)
        self.in_flight = 0  # one event loop: no lock needed

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not scope["path"].startswith(("/v1/", "/v2/")):
            await self.app(scope, receive, send)
            return
        runtime = self.runtime
        settings, metrics = runtime.settings, runtime.metrics
        if self.in_flight >= settings.max_concurrency:
            metrics.rejected.labels("overloaded").inc()
            runtime.saturation.refused()
            await send_error(send, 503, "overloaded",
                             f"more than {settings.max_concurrency} requests being computed; "
                             "retry", [(b"retry-after", str(settings.retry_after_s).encode())])
            return
        self.in_flight += 1
        metrics.in_flight.inc()
        held = True

        def free() -> None:
            nonlocal held
            if held:
                held = False
                self.in_flight -= 1
                metrics.in_flight.dec()

        async def send_freeing(message: Message) -> None:
            if message["type"] == "http.response.start":
                free()  # computed: sending the answer holds no slot
            await send(message)

        try:
            # A batch's answer may be large and streamed: its slot is freed when it starts.
            # Other answers are sent at once as the handler returns: no wrapper needed.
            await self.app(scope, receive, send_freeing if scope["path"] in _STREAMED else send)
        finally:
            free()
