"""POST /v1/contact: one pair."""
from __future__ import annotations

import orjson
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool
from starlette.responses import Response

from impactnet.service.api.deps import get_serving
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.schemas import ContactRequest, ContactResponse
from impactnet.service.codecs.json_keys import validated_unique
from impactnet.service.codecs.pairs import (
    contact_json,
    predict_checked,
    request_pair,
)
from impactnet.service.compound_inline import inline_answer
from impactnet.service.compound_solve import ORACLE, names_compound, row_json, solve_compound
from impactnet.service.runtime import Runtime

router = APIRouter(tags=["contact"])


#: Bodies up to this many bytes are parsed on the event loop, larger ones in a worker thread.
#: A pair is ~300 bytes (matrices: ~500) and parses in ~7 us; a body near the 64 KiB cap
#: (`max_pair_body_bytes`) full of unknown keys takes ~8 ms, which the loop should not wait.
INLINE_PARSE_MAX_BYTES = 4096


def parse_body(raw: bytes, content_type: str | None) -> ContactRequest:
    """The request, parsed and validated in one pass
    (:func:`impactnet.service.api.errors.validated_json`);
    a key given twice in one object is refused (:mod:`impactnet.service.codecs.json_keys`)."""
    return validated_unique(ContactRequest, raw, content_type)


_REQUEST_BODY = {"required": True, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/ContactRequest"}}}}


@router.post("/v1/contact", response_model=None, openapi_extra={"requestBody": _REQUEST_BODY},
             responses={200: {"model": ContactResponse},
                        415: {"description": "Content-Type is not JSON."}, **ERRORS},
             summary="Contact of one box pair")
async def contact(request: Request) -> Response:
    """Impact point, normal (from A towards B), depth, contact type and features of one pair.

    A body gives `size` or a scene `object`, a `position`, and exactly one of `quaternion`
    ([w, x, y, z]), `matrix` (3x3 rows) or `euler` (radians, `euler_convention`). Units:
    metres, radians. Runs inline on the event loop (a single exact pair takes ~50 us).

    `point` is the centre of pressure of the contact region (the pressure proportional to the
    local depth), on the mid-surface; it need not lie inside the hull of the manifold's
    points. `include=manifold` adds the incident face's clip against the reference face: its
    points (mid-surface) and depths, the deepest first, as before. A key given twice in one
    object is refused (422). Bodies above 64 KiB (`max_pair_body_bytes`) are 413.

    A pair that names a compound scene object (a body made of parts) is answered by the exact
    compound oracle in every mode (`predictor`: oracle): the body-level summary (`colliding`,
    `point`, `normal`, `depth`, `cluster_size`) and `contacts`, one entry per part contact
    (`part_a`, `part_b`, `point`, `normal`, `depth`, `contact_type`, `feature_a`,
    `feature_b`, `pressure`), deepest first within the answer's order (docs/service.md). A
    compound body may also be given inline as `parts` (the scene files' part format; a mesh
    as `{format, data}` in base64): bad parts are 422 naming the field.
    """
    # Read here, not through Depends: FastAPI resolves dependencies per request (~25-50 us
    # for these two, measured in process), a tenth of this route's time; the other routes
    # keep their Annotated dependencies.
    runtime: Runtime = request.app.state.runtime
    state = await get_serving(request)
    raw = await request.body()
    content_type = request.headers.get("content-type")
    if len(raw) <= INLINE_PARSE_MAX_BYTES:
        body = parse_body(raw, content_type)
    else:
        body = await run_in_threadpool(parse_body, raw, content_type)
    mode = body.mode or state.default_mode
    if body.a.parts is not None or body.b.parts is not None:  # a compound body inline
        answer = inline_answer(body, state.scene, runtime.settings.max_part_contacts_per_pose)
        runtime.metrics.record_predictions(mode, {ORACLE: 1})
        return Response(orjson.dumps(answer | {"mode": mode,
                                               "model_version": state.model_version}),
                        media_type="application/json",
                        headers={"X-Model-Version": state.model_version})
    pairs = request_pair(body, state.scene.with_compound)
    if names_compound(pairs, state.scene):  # the oracle, or the pair's learned chain
        arrays = solve_compound(pairs, state.scene, runtime.settings.max_part_contacts_per_pose,
                                runtime.settings.max_part_contacts_per_batch, state.compound,
                                mode)
        runtime.metrics.record_predictions(mode, {str(arrays["predictor"][0]): 1})
        answer = row_json(arrays, 0) | {"mode": mode, "model_version": state.model_version}
        return Response(orjson.dumps(answer), media_type="application/json",
                        headers={"X-Model-Version": state.model_version})
    contacts = predict_checked(state.predictor(mode), pairs)
    runtime.metrics.record_predictions(mode, {str(contacts.predictor[0]): 1})
    answer = contact_json(contacts, pairs, mode, state.model_version, body.include)
    return Response(orjson.dumps(answer), media_type="application/json",
                    headers={"X-Model-Version": state.model_version})
