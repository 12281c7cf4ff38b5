"""POST /v2/contact: one pair, box or compound, in the one answer shape."""
from __future__ import annotations

import orjson
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool
from starlette.responses import Response

from impactnet.service.api.deps import get_serving
from impactnet.service.api.routers import ERRORS, MOVED
from impactnet.service.api.schemas import ContactResponse
from impactnet.service.codecs.answers import row_json
from impactnet.service.codecs.json_keys import validated_unique
from impactnet.service.codecs.pair import inline_cost, part_limits, request_pairs
from impactnet.service.codecs.requests import ContactRequest
from impactnet.service.limits.body import LEASE
from impactnet.service.limits.lanes import Work
from impactnet.service.runtime import Runtime
from impactnet.service.solve import solve

router = APIRouter(tags=["contact"])

#: Bodies up to this many bytes are parsed on the event loop, larger ones in a worker thread.
#: A pair is ~300 bytes (matrices: ~500) and parses in ~7 us; a body near the 64 KiB cap
#: (`max_pair_body_bytes`) full of unknown keys takes ~8 ms, which the loop should not wait.
INLINE_PARSE_MAX_BYTES = 4096

_REQUEST_BODY = {"required": True, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/ContactRequest"}}}}


def parse_body(raw: bytes, content_type: str | None) -> ContactRequest:
    """The request, parsed and validated in one pass; a key given twice in one object is
    refused (:mod:`impactnet.service.codecs.json_keys`)."""
    return validated_unique(ContactRequest, raw, content_type)


@router.post("/v2/contact", response_model=None, openapi_extra={"requestBody": _REQUEST_BODY},
             responses={200: {"model": ContactResponse},
                        415: {"description": "Content-Type is not JSON."}, **ERRORS},
             summary="Contact of one pair of bodies (boxes or bodies made of parts)")
async def contact(request: Request) -> Response:
    """Impact point, normal (from A towards B), depth, contact type and features of one pair,
    and its part contacts (one for two boxes), in the one answer shape (docs/service.md).

    A body gives `size` (a box), a scene `object` (a box or a body made of parts) or `parts`
    (a compound body inline, in the scene files' part format; a mesh as `{format, data}` in
    base64), a `position`, and exactly one of `quaternion` ([w, x, y, z]), `matrix` (3x3
    rows) or `euler` (radians, `euler_convention`). Units: metres, radians. `margin` (m): a
    pair apart by less answers its gap as `distance` > 0 and its closest points.
    `include=manifold` adds each part contact's polygon, `include=paper_angles` the paper's
    four angles. A key given twice in one object is refused (422); bodies above 64 KiB
    (`max_pair_body_bytes`) are 413; inline parts past their limits are 413
    `geometry_too_large` naming the field and the limit.
    """
    runtime: Runtime = request.app.state.runtime
    state = await get_serving(request)
    raw = await request.body()
    content_type = request.headers.get("content-type")
    if len(raw) <= INLINE_PARSE_MAX_BYTES:
        body = parse_body(raw, content_type)
    else:
        body = await run_in_threadpool(parse_body, raw, content_type)
    mode = body.mode or state.default_mode
    limits = part_limits(runtime.settings)
    build = inline_cost((("a", body.a), ("b", body.b)), limits)
    async with Work(runtime, request.receive) as work:
        if build:  # inline parts: their hulls are built off the event loop
            pairs, notes = await work.run(build, request_pairs, body, state.scene, limits)
        else:
            pairs, notes = request_pairs(body, state.scene, limits)
        answers = await solve(work, state, pairs, mode, body.include, body.margin,
                              request.scope[LEASE])
    runtime.metrics.record_predictions(mode, {answers.predictor_of(0): 1})
    answer = row_json(answers, pairs, body.include) | ({"warnings": notes} if notes else {})
    answer |= {"mode": mode, "model_version": state.model_version}
    return Response(orjson.dumps(answer), media_type="application/json",
                    headers={"X-Model-Version": state.model_version})


@router.post("/v1/contact", include_in_schema=False)
async def contact_v1() -> Response:
    """The path of the answer shape before 0.2.0: 410 naming the new one."""
    raise MOVED("/v1/contact", "/v2/contact")
