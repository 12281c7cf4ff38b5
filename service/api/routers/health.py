"""GET /healthz (alive) and GET /readyz (ready to serve: loaded, warm, not draining)."""
from __future__ import annotations

import orjson
from fastapi import APIRouter
from starlette.responses import Response

from impactnet.service.api.deps import RuntimeDep
from impactnet.service.api.schemas import HealthResponse, ReadyResponse

router = APIRouter(tags=["health"])


@router.get("/healthz", response_model=HealthResponse, summary="Liveness")
async def healthz() -> HealthResponse:
    """200 while the process and its event loop answer."""
    return HealthResponse(status="ok")


@router.get("/readyz", response_model=None, summary="Readiness",
            responses={200: {"model": ReadyResponse},
                       503: {"model": ReadyResponse, "description": "Loading, load failed, "
                             "draining for shutdown, or saturated (Retry-After)."}})
async def readyz(runtime: RuntimeDep) -> Response:
    """200 once the scene and predictors are loaded and warmed up; 503 before that, from the
    moment a shutdown begins, and while requests have been refused as overloaded for
    `saturation_ready_s` without a pause (`saturated`: an orchestrator should route
    elsewhere or add replicas)."""
    state = runtime.serving
    version = state.model_version if state is not None else None
    reason = runtime.not_ready_reason() if not runtime.ready else runtime.saturation.reason()
    if reason is None:
        return Response(orjson.dumps({"ready": True, "model_version": version}),
                        media_type="application/json")
    body = {"ready": False, "reason": reason, "model_version": version}
    return Response(orjson.dumps(body), status_code=503, media_type="application/json",
                    headers={"Retry-After": str(runtime.settings.retry_after_s)})
