"""POST /v1/contact: one pair."""
from __future__ import annotations

import orjson
from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool
from starlette.responses import Response

from impactnet.service.api.deps import get_serving
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.schemas import ContactRequest, ContactResponse
from impactnet.service.codecs.compound_encode import row_json
from impactnet.service.codecs.json_keys import validated_unique
from impactnet.service.codecs.pairs import (
    contact_json,
    predict_checked,
    request_pair,
)
from impactnet.service.compound_inline import inline_cost, inline_group, part_limits
from impactnet.service.compound_solve import (
    CompoundCaps,
    admit,
    groups_of_pairs,
    names_compound,
    solve,
)
from impactnet.service.limits.body import LEASE
from impactnet.service.limits.lanes import Work
from impactnet.service.runtime import Runtime

router = APIRouter(tags=["contact"])


#: Bodies up to this many bytes are parsed on the event loop, larger ones in a worker thread.
#: A pair is ~300 bytes (matrices: ~500) and parses in ~7 us; a body near the 64 KiB cap
#: (`max_pair_body_bytes`) full of unknown keys takes ~8 ms, which the loop should not wait.
INLINE_PARSE_MAX_BYTES = 4096


def parse_body(raw: bytes, content_type: str | None) -> ContactRequest:
    """The request, parsed and validated in one pass
    (:func:`impactnet.service.codecs.json_keys.validated_json`);
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
    inline = body.a.parts is not None or body.b.parts is not None
    pairs = None if inline else request_pair(body, state.scene.with_compound)
    if inline or names_compound(pairs, state.scene):  # the oracle, or the pair's chain
        answer = await _compound_pair(request, runtime, state, body, pairs, mode)
        return Response(orjson.dumps(answer), media_type="application/json",
                        headers={"X-Model-Version": state.model_version})
    contacts = predict_checked(state.predictor(mode), pairs)
    runtime.metrics.record_predictions(mode, {str(contacts.predictor[0]): 1})
    answer = contact_json(contacts, pairs, mode, state.model_version, body.include)
    return Response(orjson.dumps(answer), media_type="application/json",
                    headers={"X-Model-Version": state.model_version})


def _admit_pair(body: ContactRequest, pairs, state, settings, lease, mode: str):
    """(Plan, warnings) of one compound pair: its parts (inline ones built within the
    limits), its candidates counted and its memory reserved."""
    if pairs is None:
        group, notes = inline_group(body, state.scene, part_limits(settings))
        groups = [group]
    else:
        groups, notes = groups_of_pairs(pairs, state.scene, state.compound, mode), []
    return admit(groups, 1, CompoundCaps.of(settings), lease), notes


async def _compound_pair(request: Request, runtime: Runtime, state, body, pairs,
                         mode: str) -> dict:
    """The answer of a pair with a compound body: admitted in the small lane, solved in the
    lane its work chooses, under the request's deadline (:mod:`impactnet.service.limits.
    lanes`)."""
    settings, lease = runtime.settings, request.scope[LEASE]
    build = 0.0 if pairs is not None else inline_cost(body, part_limits(settings))
    async with Work(runtime, request.receive) as work:
        plan, notes = await work.run(build, _admit_pair, body, pairs, state, settings, lease,
                                     mode)
        arrays = await work.run(plan.work, solve, plan, CompoundCaps.of(settings), mode)
    predictor = str(arrays.predictor_names[arrays.predictor[0]])
    runtime.metrics.record_predictions(mode, {predictor: 1})
    return (row_json(arrays, 0) | ({"warnings": notes} if notes else {})
            | {"mode": mode, "model_version": state.model_version})
