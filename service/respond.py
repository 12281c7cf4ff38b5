"""Small ASGI helpers of the middleware: a base class, a request header, an error envelope."""
from __future__ import annotations

from starlette.types import ASGIApp, Scope, Send

from impactnet.service.errors import error_body
from impactnet.service.runtime import Runtime

_JSON_HEADERS = [(b"content-type", b"application/json")]


class Middleware:
    """Pure ASGI middleware of the service: the wrapped app and the runtime. A subclass's
    ``__call__`` passes anything but ``http`` (the lifespan) straight to the app."""

    def __init__(self, app: ASGIApp, runtime: Runtime) -> None:
        self.app, self.runtime = app, runtime


def header(scope: Scope, name: bytes) -> bytes | None:
    """The first value of the (lower-case) header ``name``, or None."""
    for key, value in scope["headers"]:
        if key == name:
            return value
    return None


async def send_error(send: Send, status: int, error: str, message: str,
                     headers: list[tuple[bytes, bytes]] | None = None,
                     more_body: bool = False) -> None:
    """Answer with the JSON error envelope (:func:`impactnet.service.errors.error_body`);
    ``more_body``: the answer is complete for the client (its Content-Length) but not yet for
    the server, which may still read the request (the caller ends it with an empty body)."""
    body = error_body(status, error, message)
    await send({"type": "http.response.start", "status": status,
                "headers": _JSON_HEADERS + [(b"content-length", str(len(body)).encode())]
                + (headers or [])})
    await send({"type": "http.response.body", "body": body, "more_body": more_body})
