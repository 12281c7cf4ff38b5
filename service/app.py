"""``create_app(settings)``: the FastAPI application of impactnet.

Lifespan: the scene, the learned bundle (checksums, scene hash, smoke test) and the predictors are
loaded and warmed up in a worker thread (:mod:`impactnet.service.state`), in the background by
default, so /healthz answers at once and /readyz says 503 until the state is installed; leaving the
lifespan (shutdown) turns /readyz to 503 again. Where the bundle folder is a store, the lifespan
also runs its follower (:mod:`impactnet.service.store_follow`) and cancels it on shutdown. The admin
reload route (:mod:`impactnet.service.api.routers.admin`) is included only when an admin token is
configured.
"""
from __future__ import annotations

import asyncio
import contextlib
import logging

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi

from impactnet import __version__
from impactnet.service.api import errors
from impactnet.service.api.middleware import ConcurrencyLimit, RequestContext
from impactnet.service.api.routers import (
    admin,
    batch,
    contact,
    docs,
    frame,
    health,
    metrics,
    models,
)
from impactnet.service.api.schemas import BatchRequest, ContactRequest, ReloadRequest
from impactnet.service.codecs.requests import FrameRequest, WorldRequest
from impactnet.service.limits.body import BodyReader
from impactnet.service.predictors import ServingState
from impactnet.service.reload import Reloader
from impactnet.service.runtime import Runtime
from impactnet.service.settings import Settings
from impactnet.service.store_follow import follow

log = logging.getLogger("impactnet.service")

DESCRIPTION = """
Box-box contact for a real-time crane simulator: impact point, contact normal (from A towards
B), penetration depth, contact type and features. Modes: `exact` (the separating-axis solver,
always served), and with a learned bundle `single` (one MLP), `committee` (exact region
labeller -> that region's expert committee for the point, with a confidence) and `auto` (the
committee, with the exact solver for the pairs it is unsure of or has no model for). Each
answer names the `predictor` that answered it. Default mode: `auto` with a bundle, `exact`
without (GET /v1/models).

Conventions (GET /v1/models: `conventions`): `normal` points from A towards B; `point` is the
centre of pressure of the contact region (pressure proportional to the local penetration
depth), on the mid-surface, and need not lie inside the hull of the manifold's points;
`include=manifold` gives, as before, the incident face's clip against the reference face: its
points and depths (>= 0), the deepest first.

Units: metres and radians. A body is `size` (full edge lengths) or a scene `object`, a
`position` (centre, world frame) and exactly one orientation: `quaternion` [w, x, y, z]
(normalised here), `matrix` (3x3 rows, v_world = R v_body) or `euler` (radians; `zyx` =
[roll, pitch, yaw] with R = Rz(yaw) Ry(pitch) Rx(roll), or `xyz` = [a, b, c] with
R = Rx(a) Ry(b) Rz(c)).

Errors share one JSON envelope (`error`, `message`, `detail` naming the field, the reason and
for batches the rows, at most 20 items and one that counts the rest, `request_id`): 422
invalid input (a key given twice in one JSON object included), 422 `unsupported_pair` (a
strict learned mode has no model for the pair's box sizes), 413 body or batch too large (64
KiB for a single pair, 32 MiB for a JSON batch, 64 MiB for npz), 408 `body_timeout` (the body
did not arrive within `body_timeout_s`), 409 mode not served (no bundle), 503 not ready /
draining / overloaded (no compute slot, or no room in the memory budget; Retry-After),
415/406 media types. `POST /v1/admin/reload` exists only when an admin token is configured.
Every response carries `X-Request-ID` (yours if you sent a sane one) and `X-Replica` (the
replica that answered, GET /v1/models: `replica`); /v1 answers carry
`X-Model-Version`.
""" + batch.LAYOUT


def _openapi(app: FastAPI, admin: bool):
    """The generated schema plus the request models, which the routes parse themselves (the
    batch with NumPy, the single pair and the reload with pydantic's JSON parser), so FastAPI
    does not add them by itself."""
    requests = (ContactRequest, BatchRequest, FrameRequest, WorldRequest) + (
        (ReloadRequest,) if admin else ())

    def build() -> dict:
        if app.openapi_schema is None:
            schema = get_openapi(title=app.title, version=app.version,
                                 description=app.description, routes=app.routes)
            components = schema.setdefault("components", {}).setdefault("schemas", {})
            for model in requests:
                extra = model.model_json_schema(ref_template="#/components/schemas/{model}")
                components.update(extra.pop("$defs", {}))
                components[model.__name__] = extra
            app.openapi_schema = schema
        return app.openapi_schema
    return build


def create_app(settings: Settings | None = None, state: ServingState | None = None) -> FastAPI:
    """The application. ``state``: an already built serving state (the CLI builds it first to
    fail fast on a bad scene); otherwise the lifespan builds it from ``settings``."""
    settings = settings or Settings()
    runtime = Runtime(settings)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI):
        runtime.draining = False  # a (re)start serves again; test clients re-enter it
        task = asyncio.create_task(runtime.load(state))
        following = asyncio.create_task(follow(runtime, app.state.reloader, task))
        if not settings.load_in_background:
            await task
        try:
            yield
        finally:
            runtime.begin_drain()
            for running in (following, task):  # the follower first: it awaits the load
                if not running.done():
                    running.cancel()
                    with contextlib.suppress(asyncio.CancelledError):
                        await running
            runtime.follower = None

    app = FastAPI(title="impactnet", version=__version__, description=DESCRIPTION,
                  lifespan=lifespan, docs_url=None, redoc_url=None)  # offline: routers.docs
    app.state.runtime = runtime
    app.state.reloader = Reloader(runtime)
    errors.install(app)
    admin_enabled = bool(settings.admin_token and settings.admin_token.get_secret_value())
    routers = (contact, batch, frame, models, health, metrics, docs)
    for module in routers + ((admin,) if admin_enabled else ()):
        app.include_router(module.router)
    # add_middleware prepends: the last one added is the outermost.
    app.add_middleware(ConcurrencyLimit, runtime=runtime)
    app.add_middleware(BodyReader, runtime=runtime)
    app.add_middleware(RequestContext, runtime=runtime)
    app.openapi = _openapi(app, admin_enabled)
    return app
