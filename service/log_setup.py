"""Structured logs: one JSON object per line, carrying the request id of the current request.

The request id comes from the client's ``X-Request-ID`` header when it is sane (1-128 chars of
``[A-Za-z0-9._:-]``), else a fresh one; it is echoed in the response header and in every log
line and error body written while the request is served (a context variable, so it follows
the request into the thread pool).

(Import as ``impactnet.service.log_setup``; inside the package ``import logging`` still means the
standard library, since absolute imports never look in the package folder.)
"""
from __future__ import annotations

import contextvars
import logging
import re
import secrets
import sys
import time

import orjson

request_id_var: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "impactnet_request_id", default=None)

_REQUEST_ID = re.compile(r"[A-Za-z0-9._:-]{1,128}")
# LogRecord attributes that are not "extra" fields.
_STANDARD = set(logging.makeLogRecord({}).__dict__) | {"message", "asctime", "taskName",
                                                        "color_message"}


def request_id_from(header: bytes | None) -> str:
    """The client's request id if acceptable, else a new random one (32 hex chars)."""
    if header:
        try:
            text = header.decode("ascii")
        except UnicodeDecodeError:
            text = ""
        if _REQUEST_ID.fullmatch(text):
            return text
    return secrets.token_hex(16)  # as random as uuid4().hex, in a quarter of its time


class JsonFormatter(logging.Formatter):
    """``{"ts", "level", "logger", "msg", "request_id", ...extra fields}`` on one line."""

    def format(self, record: logging.LogRecord) -> str:
        out = {
            "ts": time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(record.created))
            + f".{int(record.msecs):03d}Z",
            "level": record.levelname.lower(),
            "logger": record.name,
            "msg": record.getMessage(),
        }
        rid = getattr(record, "request_id", None) or request_id_var.get()
        if rid:
            out["request_id"] = rid
        for key, value in record.__dict__.items():
            if key not in _STANDARD and key not in out:
                out[key] = value
        if record.exc_info:
            out["exc"] = self.formatException(record.exc_info)
        return orjson.dumps(out, default=str).decode()


def configure(level: str = "info", stream=None) -> None:
    """Route the root, uvicorn and impactnet loggers to one JSON handler on stderr."""
    handler = logging.StreamHandler(stream or sys.stderr)
    handler.setFormatter(JsonFormatter())
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(level.upper())
    for name in ("uvicorn", "uvicorn.error", "uvicorn.access", "impactnet"):
        logger = logging.getLogger(name)
        logger.handlers[:] = []
        logger.propagate = True
    # uvicorn's own access log is replaced by ours (with request ids).
    logging.getLogger("uvicorn.access").setLevel(logging.WARNING)
