"""FastAPI dependencies (``Annotated`` aliases used by the routers).

``async def`` on purpose: FastAPI runs plain ``def`` dependencies in the thread pool, which
costs a thread hop (~0.1-0.3 ms) per dependency per request.
"""
from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from impactnet.service.errors import NotReady
from impactnet.service.predictors import ServingState
from impactnet.service.runtime import Runtime


async def get_runtime(request: Request) -> Runtime:
    return request.app.state.runtime


async def get_serving(request: Request) -> ServingState:
    """The serving state, read once per request (503 until one is loaded and warm)."""
    runtime: Runtime = request.app.state.runtime
    state = runtime.serving
    if state is None or not runtime.warm:
        raise NotReady(runtime.not_ready_reason() or "not ready",
                       runtime.settings.retry_after_s)
    return state


RuntimeDep = Annotated[Runtime, Depends(get_runtime)]
ServingDep = Annotated[ServingState, Depends(get_serving)]
