"""POST /v2/frame (every contact among many bodies, and the gap before contact) and POST
/v2/worlds (a static world registered once)."""
from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request
from starlette.responses import Response

from impactnet.models.frame import frame_answer
from impactnet.service import frame_steps as steps
from impactnet.service.api.deps import RuntimeDep, ServingDep
from impactnet.service.api.frame_schemas import FrameResponse, WorldResponse
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.routers.batch import media_type, response_type
from impactnet.service.api.schemas import EulerConvention, Include, Mode
from impactnet.service.codecs import columns as col
from impactnet.service.codecs.frame_answers import frame_json, frame_npz
from impactnet.service.codecs.stream import answer_response
from impactnet.service.errors import ServiceError
from impactnet.service.limits.body import LEASE
from impactnet.service.limits.lanes import Work
from impactnet.service.solve import solve
from impactnet.service.worlds import world_name

router = APIRouter(tags=["frame"])

NPZ_FRAME = """
**npz frames**: members `id` (n,) unicode, `object` (n,) unicode or `size` (n, 3), `position`
(n, 3), one of `quaternion` (n, 4), `matrix` (n, 3, 3), `euler` (n, 3), and optionally
`contype`, `conaffinity` (n,) integers; the options in the query string. The npz answer holds
the batch's members for the pairs found, with `a` and `b` (their bodies' ids) and `n_bodies`.
"""


def _body(kind: str) -> dict:
    return {"required": True, "content": {
        col.JSON: {"schema": {"$ref": f"#/components/schemas/{kind}"}},
        col.NPZ: {"schema": {"type": "string", "format": "binary"}}}}


def _content_type(request: Request) -> str:
    kind = media_type(request.headers.get("content-type"))
    if kind not in ("", col.JSON, col.NPZ) and not kind.endswith("+json"):
        raise ServiceError(415, "unsupported_media_type", f"Content-Type {kind!r}; send "
                           f"{col.JSON} or {col.NPZ}")
    return kind


@router.post(
    "/v2/frame", response_model=None, summary="Every contact among many bodies",
    openapi_extra={"requestBody": _body("FrameRequest")},
    responses={200: {"model": FrameResponse, "content": {
        col.NPZ: {"schema": {"type": "string", "format": "binary"}}}},
        409: {"description": "`unknown_world`: register the world again (POST /v2/worlds); "
              "or the mode is not served."}, **ERRORS},
    description="The bodies of one frame (each an `id`, a scene `object`, a `size` or inline "
    "`parts`, a `position` and one orientation), optionally joined to a registered static "
    "`world`: the compiled broadphase over the bodies finds the pairs whose bounds meet "
    "within `margin` (and that the contype/conaffinity filter and `pairs=scene` let touch), "
    "and each is answered as POST /v2/contact answers it with the same margin. The answer "
    "lists the pairs that touch or lie within the margin, with their bodies' ids (A: the "
    "body that comes first, the world's bodies first). Admitted, bounded and cancelled like "
    "a batch: `max_frame_bodies` (413 `too_many_bodies`), the pairs found held to "
    "`max_batch_pairs` (413 `too_many_body_pairs`), the candidate and contact caps, the "
    "memory budget and the deadline. A refusal names the body by its id.\n" + NPZ_FRAME)
async def frame(
    request: Request, runtime: RuntimeDep, state: ServingDep,
    world: Annotated[str | None, Query(description="npz frames: the world's name.")] = None,
    margin: Annotated[float | None, Query(description="npz frames: metres.")] = None,
    pairs: Annotated[str | None, Query(description="npz frames: all | scene.")] = None,
    mode: Annotated[Mode | None, Query(description="npz frames: the mode.")] = None,
    include: Annotated[list[Include] | None, Query(description="npz frames.")] = None,
    euler_convention: Annotated[EulerConvention | None, Query()] = None,
) -> Response:
    binary = _content_type(request) == col.NPZ
    answer_type = response_type(request.headers.get("accept"))
    body = await request.body()
    lease, settings = request.scope[LEASE], runtime.settings
    query = {"world": world, "margin": margin, "pairs": pairs, "mode": mode,
             "include": include, "euler_convention": euler_convention}
    notes: list[str] = []
    async with Work(runtime, request.receive) as work:
        done = await work.chain(steps.parse_cost(body), steps.advance, steps.Prepared(), (
            body, binary, query, settings, lease, state.scene, runtime.worlds, notes))
        options, bodies, found = done.parsed.options, done.bodies, done.found
        chosen = options.mode or state.default_mode
        answers = await solve(work, state, found.pairs, chosen, options.include,
                              options.margin, lease, separated=False)
        result = frame_answer(bodies, found, answers)
        runtime.metrics.record_answers(chosen, result.answers)
        headers = {"X-Model-Version": state.model_version}
        if answer_type == col.JSON:
            text = await work.run(len(result.answers), frame_json, result, options.include,
                                  chosen, state.model_version, options.world, notes)
            return Response(text, media_type=col.JSON, headers=headers)
        pieces = frame_npz(result, options.include, chosen, state.model_version)
        return await answer_response(work, pieces, result.answers, headers,
                                     settings.send_timeout_s, answer_type)


@router.post(
    "/v2/worlds", response_model=WorldResponse, summary="Register a static world",
    openapi_extra={"requestBody": _body("WorldRequest")},
    responses={**{k: v for k, v in ERRORS.items() if k != 409}},
    description="The bodies a simulator never moves (the yard, the cell guides), decoded once "
    "and kept by this replica under a name made from their content (the same bodies give the "
    "same name on every replica), so that a frame sends only the bodies that moved and names "
    "the world. A replica keeps `max_worlds`, the least recently used forgotten first; a "
    "frame naming a world the replica does not hold gets 409 `unknown_world`. Bodies as in "
    "POST /v2/frame (JSON `{bodies, euler_convention}`, or npz columns).")
async def register_world(
    request: Request, runtime: RuntimeDep, state: ServingDep,
    euler_convention: Annotated[EulerConvention | None, Query()] = None,
) -> dict:
    binary = _content_type(request) == col.NPZ
    body = await request.body()
    lease, settings = request.scope[LEASE], runtime.settings
    async with Work(runtime, request.receive) as work:
        parsed = await work.run(steps.parse_cost(body), steps.parse, body, binary,
                                {"euler_convention": euler_convention}, settings, lease, True)
        bodies = await work.run(steps.decode_cost(parsed, settings), steps.decode, parsed,
                                state.scene, settings, lease)
    name = world_name(bodies, state.scene.hash)
    known = runtime.worlds.holds(name)
    runtime.worlds.add(name, bodies)
    return {"world": name, "bodies": len(bodies), "created": not known}
