"""POST /v1/admin/reload: swap the learned bundle without a restart
(:mod:`impactnet.service.reload`).

The route exists only when ``IMPACTNET_ADMIN_TOKEN`` is set
(:func:`impactnet.service.app.create_app` includes this router then; otherwise the path answers 404
like any unknown one). The token comes as ``Authorization: Bearer <token>``: none (or another
scheme) is 401, a wrong one 403, compared in constant time.
"""
from __future__ import annotations

import asyncio
import hmac
import time
from typing import Annotated

import orjson
from fastapi import APIRouter, Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.responses import Response

from impactnet.service.api.deps import RuntimeDep
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.schemas import ErrorResponse, ReloadRequest, ReloadResponse
from impactnet.service.codecs.json_keys import validated_unique
from impactnet.service.errors import ReloadFailed, ServiceError

router = APIRouter(tags=["admin"])
bearer = HTTPBearer(auto_error=False, scheme_name="AdminToken",
                    description="The admin token (IMPACTNET_ADMIN_TOKEN).")

_REQUEST_BODY = {"required": False, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/ReloadRequest"}}}}
_CHALLENGE = {"WWW-Authenticate": 'Bearer realm="impactnet-admin"'}
#: Seconds the route waits beyond the reload's own deadline, so that a reload that gives up
#: by itself (the lock, the install check) answers with its own reason.
ANSWER_GRACE_S = 1.0


def check_token(credentials: HTTPAuthorizationCredentials | None, token: str) -> None:
    """401 without a bearer token, 403 with a wrong one."""
    if credentials is None or not credentials.credentials:
        raise ServiceError(401, "unauthorized", "send the admin token as "
                           "'Authorization: Bearer <token>'", headers=_CHALLENGE)
    if not hmac.compare_digest(credentials.credentials.encode(), token.encode()):
        raise ServiceError(403, "forbidden", "wrong admin token")


def parse_body(raw: bytes, content_type: str | None) -> ReloadRequest:
    """An empty body, or a JSON object ``{"bundle": "<folder>"}`` (both keys optional)."""
    if not raw:  # whitespace alone is not JSON: it goes to the parser and is refused
        return ReloadRequest()
    return validated_unique(ReloadRequest, raw, content_type)


@router.post(
    "/v1/admin/reload", response_model=None, summary="Reload the learned bundle",
    openapi_extra={"requestBody": _REQUEST_BODY},
    responses={200: {"model": ReloadResponse},
               401: {"model": ErrorResponse, "description": "No bearer token."},
               403: {"model": ErrorResponse, "description": "Wrong token."},
               409: {"model": ErrorResponse, "description": "Cannot reload now: not ready, "
                     "or no bundle path configured and none given (`reload_failed`)."},
               415: {"description": "Content-Type is not JSON."},
               422: {"model": ErrorResponse, "description": "Invalid body, or the bundle "
                     "failed a step (`reload_failed`, `step`: also when a file is not a "
                     "regular file or above its size cap, and when the reload passed "
                     "`reload_timeout_s`); the old bundle keeps serving."},
               413: ERRORS[413], 503: ERRORS[503]})
async def reload(
    request: Request, runtime: RuntimeDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)],
) -> Response:
    """Load a bundle beside the serving one (the requested folder, or the configured one),
    verify its checksums and scene, run the smoke test against the exact solver, warm it up
    and swap it in atomically. Any failure leaves the old bundle serving and answers with
    the step that failed. Reloads are serialised."""
    check_token(credentials, runtime.settings.admin_token.get_secret_value())
    body = parse_body(await request.body(), request.headers.get("content-type"))
    reloader = request.app.state.reloader
    timeout = runtime.settings.reload_timeout_s
    try:  # a thread of its own: one stuck on a file is abandoned, never awaited
        report = await asyncio.wait_for(asyncio.to_thread(
            reloader.reload, body.bundle, time.monotonic() + timeout),
            timeout + ANSWER_GRACE_S)
    except TimeoutError:
        serving = runtime.serving
        raise ReloadFailed(422, reloader.step or "read", f"the reload did not finish within "
                           f"{timeout:g} s (reload_timeout_s); the new bundle is not installed",
                           body.bundle, serving.model_version if serving else None) from None
    return Response(orjson.dumps(report), media_type="application/json",
                    headers={"X-Model-Version": report["model_version"]})
