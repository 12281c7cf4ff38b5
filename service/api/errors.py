"""The API's side of the errors (:mod:`impactnet.service.errors`): each exception becomes the one
JSON envelope, FastAPI's and Starlette's own errors (validation, 404, 405, ...) too, and a refusal
by a limit is counted in /metrics by that limit's name."""
from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import Response

from impactnet.service.errors import (
    LimitRefused,
    ServiceError,
    capped,
    error_body,
    validation_items,
)

log = logging.getLogger("impactnet.service")

#: Error code of a bare HTTP status (404 from routing, 405, ...).
STATUS_CODES = {400: "bad_request", 401: "unauthorized", 403: "forbidden", 404: "not_found",
                405: "method_not_allowed", 406: "not_acceptable", 408: "body_timeout",
                409: "mode_unavailable",
                413: "body_too_large", 415: "unsupported_media_type", 422: "invalid_input",
                500: "internal_error", 503: "unavailable", 504: "deadline_exceeded"}


def error_response(status: int, error: str, message: str, detail: list[dict] | None = None,
                   headers: dict[str, str] | None = None, **extra) -> Response:
    return Response(error_body(status, error, message, detail, **extra), status_code=status,
                    headers=headers, media_type="application/json")


async def _service_error(request: Request, exc: ServiceError) -> Response:
    if isinstance(exc, LimitRefused):  # refusals counted by the limit that refused them
        runtime = getattr(request.app.state, "runtime", None)
        if runtime is not None:
            runtime.metrics.rejected.labels(exc.limit).inc()
    return error_response(exc.status_code, exc.error, exc.message, exc.items, exc.headers,
                          **exc.extra)


async def _http_error(request: Request, exc: StarletteHTTPException) -> Response:
    code = STATUS_CODES.get(exc.status_code, "http_error")
    return error_response(exc.status_code, code, str(exc.detail), None, exc.headers)


async def _validation_error(request: Request, exc: RequestValidationError) -> Response:
    items = validation_items(exc.errors())
    message = "; ".join(f"{i['field']}: {i['reason']}" for i in items[:5])
    return error_response(422, "invalid_input", message or "invalid request", capped(items))


async def _unexpected(request: Request, exc: Exception) -> Response:
    log.exception("unhandled error", extra={"path": request.url.path})
    return error_response(500, "internal_error", "internal error (a bug); quote the "
                          "request id when reporting it")


def install(app: FastAPI) -> None:
    """Register the handlers on ``app``."""
    app.add_exception_handler(ServiceError, _service_error)
    app.add_exception_handler(StarletteHTTPException, _http_error)
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.add_exception_handler(Exception, _unexpected)
