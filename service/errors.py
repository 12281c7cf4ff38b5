"""The service's errors: one JSON envelope for every non-2xx answer.

Every error body is ``{"error": code, "message": text, "detail": [{"field", "reason", "type",
"loc", "rows"}], "request_id": id}`` (see :class:`impactnet.service.api.schemas.ErrorResponse`),
with ``limit`` for a refusal by a limit. Input faults are 422 and name the field; a genuine bug
is the only 500, logged with its traceback. The exceptions are plain (the serving core raises
them); the API turns them into answers (:mod:`impactnet.service.api.errors`).
"""
from __future__ import annotations

import orjson

from impactnet.service.log_setup import request_id_var

#: Most problems listed in an error's ``detail``; the rest are counted in one last item, so
#: that an error answer stays small whatever the body (300,000 unknown keys once made a 31 MB
#: answer out of a 3.5 MB request).
MAX_DETAIL_ITEMS = 20


class ServiceError(Exception):
    """An error answer: its status, code, message, detail items, headers and extra fields."""

    def __init__(self, status: int, error: str, message: str, detail: list[dict] | None = None,
                 headers: dict[str, str] | None = None, **extra):
        super().__init__(message)
        self.status_code, self.headers = status, headers
        self.error, self.message, self.items, self.extra = error, message, detail or [], extra


def item(field: str, reason: str, type_: str = "value_error", rows=None, loc=None) -> dict:
    """One entry of an error's ``detail`` list."""
    out = {"field": field, "reason": reason, "type": type_,
           "loc": list(loc) if loc is not None else [p for p in field.replace("]", "").replace(
               "[", ".").split(".") if p]}
    if rows is not None:
        out["rows"] = [int(r) for r in list(rows)[:20]]
    return out


class InputError(ServiceError):
    """422: a request field is not usable; ``rows`` (batch) name the offending pairs."""

    def __init__(self, field: str, reason: str, rows=None, type_: str = "value_error"):
        shown = f" (rows {[int(r) for r in list(rows)[:10]]})" if rows is not None else ""
        super().__init__(422, "invalid_input", f"{field}: {reason}{shown}",
                         [item(field, reason, type_, rows)])


class InvalidBody(ServiceError):
    """422 from a pydantic ValidationError of a body parsed by the route itself."""

    def __init__(self, errors) -> None:
        items = validation_items(errors)
        message = "; ".join(f"{i['field']}: {i['reason']}" for i in items[:5])
        super().__init__(422, "invalid_input", message or "invalid request", capped(items))


def capped(items: list[dict]) -> list[dict]:
    """The first :data:`MAX_DETAIL_ITEMS` items, and one more that counts the others."""
    if len(items) <= MAX_DETAIL_ITEMS:
        return items
    more = len(items) - MAX_DETAIL_ITEMS
    return items[:MAX_DETAIL_ITEMS] + [item("body", f"{more} more problems not listed",
                                            "too_many_errors", loc=["body"])]


class DuplicateKey(ServiceError):
    """422: a JSON object names the same key twice (which one wins is parser-defined)."""

    def __init__(self, field: str) -> None:
        reason = "duplicate key: the same key appears twice in one JSON object"
        super().__init__(422, "invalid_input", f"{field}: {reason}",
                         [item(field, reason, "duplicate_key")])


class PayloadTooLarge(ServiceError):
    """413: the body or the batch exceeds the configured limit."""

    def __init__(self, error: str, message: str):
        # An unread rest of the body may still be in flight: close the connection after.
        close = {"Connection": "close"} if error == "body_too_large" else None
        super().__init__(413, error, message, headers=close)


class LimitRefused(ServiceError):
    """413: the request's work or geometry passes a limit (a setting, named in ``limit``)
    before any of the costly work is done: it could never be admitted as it is."""

    def __init__(self, error: str, field: str, reason: str, limit: str) -> None:
        super().__init__(413, error, f"{field}: {reason}", [item(field, reason, error)],
                         limit=limit)
        self.limit = limit


class DeadlineExceeded(ServiceError):
    """504 ``deadline_exceeded``: the request computed past ``compute_deadline_s`` and its
    work was stopped. A front must not replay it on another replica."""

    def __init__(self, seconds: float, deadline_s: float) -> None:
        super().__init__(504, "deadline_exceeded", f"the request computed for {seconds:.1f} s, "
                         f"past compute_deadline_s ({deadline_s:g} s); its work was stopped. "
                         "Send fewer pairs per request", limit="compute_deadline_s")


class ModeUnavailable(ServiceError):
    """The requested mode cannot answer: no bundle loaded (409), or the bundle does not cover
    the pair (422, a property of the input). Names the mode and why."""

    def __init__(self, mode: str, reason: str, status: int = 409):
        super().__init__(status, "mode_unavailable", f"mode {mode!r} is unavailable: {reason}",
                         [item("mode", reason, "mode_unavailable")], mode=mode)


class UnsupportedPair(ServiceError):
    """422: a strict learned mode (single, committee) has no model for the box sizes of a
    pair (or of the batch rows ``rows``); mode ``auto`` would send them to the exact solver."""

    def __init__(self, mode: str, rows, covered, batch: bool):
        self.rows, self.covered = [int(r) for r in rows], list(covered)
        covered = ", ".join(covered) or "none"
        hint = "use mode 'auto' (exact fallback) or 'exact' for other boxes"
        if batch:
            rows = [int(r) for r in rows]
            shown = f"{rows[:10]}{' ...' if len(rows) > 10 else ''}"
            reason = (f"mode {mode!r} has no model for the box sizes of {len(rows)} pair(s), "
                      f"rows {shown}; the bundle covers {covered}")
            detail = [item("pairs", reason, "unsupported_pair", rows, loc=["pairs"])]
        else:
            reason = (f"mode {mode!r} has no model for the box sizes of this pair; the bundle "
                      f"covers {covered}")
            detail = [item("pair", reason, "unsupported_pair", loc=["a", "b"])]
        super().__init__(422, "unsupported_pair", f"{reason}; {hint}", detail, mode=mode)


class ReloadFailed(ServiceError):
    """An admin reload failed at ``step``; the previous bundle keeps serving. 409 when the
    server cannot reload now (nothing to reload, not ready), 422 when the bundle is at fault
    (unreadable, altered, another scene, failing the smoke test)."""

    def __init__(self, status: int, step: str, message: str, bundle: str | None,
                 serving: str | None):
        super().__init__(status, "reload_failed", f"reload failed at step {step!r}: {message}",
                         [item("bundle", message, f"reload_{step}", loc=["bundle"])],
                         step=step, bundle=bundle, model_version=serving)


class Overloaded(ServiceError):
    """503 ``overloaded`` with Retry-After: no room now (compute slots or memory budget)."""

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(503, "overloaded", message,
                         headers={"Retry-After": str(retry_after_s)})


class NotReady(ServiceError):
    """503: loading / warming up, draining, or the load failed."""

    def __init__(self, reason: str, retry_after_s: int = 1):
        super().__init__(503, "not_ready", reason,
                         headers={"Retry-After": str(retry_after_s)})


def _field_of(loc) -> str:
    parts = [p for p in loc if p != "body"] if loc and loc[0] == "body" else list(loc)
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "body"


def validation_items(errors) -> list[dict]:
    """Pydantic / FastAPI validation errors as envelope items (never echoing the input)."""
    out = []
    for e in errors:
        loc = tuple(e.get("loc", ()))
        if e.get("type") == "json_invalid":
            ctx = e.get("ctx") or {}
            reason = f"malformed JSON: {ctx.get('error', 'decode error')}"
            if len(loc) > 1:
                reason += f" at character {loc[1]}"
            out.append(item("body", reason, "json_invalid", loc=["body"]))
            continue
        reason = str(e.get("msg", "invalid"))
        if reason.startswith("Value error, "):
            reason = reason[len("Value error, "):]
        out.append(item(_field_of(loc), reason, str(e.get("type", "value_error")),
                        loc=[str(p) if not isinstance(p, int) else p for p in loc]))
    return out


def error_body(status: int, error: str, message: str, detail: list[dict] | None = None,
               **extra) -> bytes:
    """The JSON envelope of an error (module docstring)."""
    body = {"error": error, "message": message, "detail": detail or [],
            "request_id": request_id_var.get(), **extra}
    return orjson.dumps(body)
