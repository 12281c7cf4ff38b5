"""POST /v1/contact/batch: N pairs, columnar JSON or npz in and out."""
from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request
from starlette.responses import Response

from impactnet.service import batch_steps as steps
from impactnet.service.api.deps import RuntimeDep, ServingDep
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.schemas import BatchResponse, EulerConvention, Include, Mode
from impactnet.service.codecs import columns as col
from impactnet.service.codecs import compound_encode
from impactnet.service.codecs.answer_encode import StreamedAnswer, json_pieces
from impactnet.service.errors import ServiceError
from impactnet.service.limits.body import LEASE
from impactnet.service.limits.lanes import Work

router = APIRouter(tags=["contact"])

LAYOUT = """
**Binary layout** (`Content-Type: application/x-npz` request, `Accept: application/x-npz`
answer; either may be JSON while the other is npz). A NumPy `.npz` archive (zip of `.npy`
members, as written by `numpy.savez`; deflated members are accepted), read with
`allow_pickle=False`: object arrays are refused. Request members are the JSON columns
(`a_size`, `a_object`, `a_position`, `a_quaternion` | `a_matrix` | `a_euler`, same for `b_`),
numbers of any integer or float dtype (converted to float64), names as unicode (`<U`) arrays;
options go in the query string (`?mode=exact&include=manifold`). Answer members:
`colliding` bool (N,), `point` and `normal` `<f8` (N, 3), `depth` and `confidence` `<f8` (N,),
`contact_type_code` int8 (N,) indexing `contact_type_names` (`<U`, 7), `feature_a`,
`feature_b`, `axis` int8 (N,), `predictor_code` int8 (N,) indexing `predictor_names`,
`mode` and `model_version` (0-d `<U`); with include=manifold `manifold_count` int8 (N,),
`manifold_points` `<f8` (N, 8, 3), `manifold_depths` `<f8` (N, 8); with include=paper_angles
`paper_angles` `<f8` (N, 4), NaN rows where there is no contact.

**Compound bodies.** Rows that name a compound scene object are answered by the exact compound
oracle (every mode; `predictor` is `oracle`): summary columns `colliding`, `point`, `normal`,
`depth`, `cluster_size` of N, and the part contacts in a ragged layout: JSON `contacts` =
{`offsets` (N + 1), `part_a`, `part_b`, `point`, `normal`, `depth`, `contact_type`,
`feature_a`, `feature_b`, `pressure`}, row i's contacts at `offsets[i]:offsets[i+1]`; npz
members `contact_offsets` and `contact_<name>` (`contact_type` for the type). Caps:
`max_part_contacts_per_pose`, `max_part_contacts_per_batch` (413 `too_many_part_contacts`
naming the cap).
"""

_REQUEST_BODY = {
    "required": True,
    "content": {
        col.JSON: {"schema": {"$ref": "#/components/schemas/BatchRequest"}},
        col.NPZ: {"schema": {"type": "string", "format": "binary"}},
    },
}


def _media_type(value: str | None) -> str:
    return (value or "").split(";", 1)[0].strip().lower()


def _response_type(accept: str | None) -> str:
    """npz when the client accepts it, JSON when it accepts JSON or anything; else 406."""
    kinds = {_media_type(part) for part in (accept or "*/*").split(",")}
    if col.NPZ in kinds:
        return col.NPZ
    if kinds & {col.JSON, "*/*", "application/*", ""} or any(k.endswith("+json") for k in kinds):
        return col.JSON
    raise ServiceError(406, "not_acceptable", f"cannot answer as {accept!r}; accepted: "
                       f"{col.JSON}, {col.NPZ}")


@router.post(
    "/v1/contact/batch", response_model=None, summary="Contacts of N box pairs",
    openapi_extra={"requestBody": _REQUEST_BODY},
    responses={200: {"model": BatchResponse, "content": {
        col.NPZ: {"schema": {"type": "string", "format": "binary"}}}},
        406: {"description": "Accept names neither JSON nor npz."},
        415: {"description": "Content-Type is neither JSON nor npz."}, **ERRORS},
    description="Columnar batch: every column holds one value (broadcast) or an array of N; "
    "the answer has one entry per pair in every column. Validation, scoring and encoding are "
    "vectorised (no Python loop over pairs) and run in a worker thread, `max_batch_workers` "
    "batches at a time. Limits: JSON bodies up to `max_json_body_bytes` (32 MiB: 100,000 "
    "pairs with quaternions), npz up to `max_body_bytes`, `max_batch_pairs` pairs; a batch "
    "reserves its memory in the server's budget first (503 `overloaded` with Retry-After when "
    "there is no room now, 413 when it could never fit). A JSON object that repeats a key is "
    "422. Large JSON answers are streamed (chunked).\n" + LAYOUT)
async def batch(
    request: Request, runtime: RuntimeDep, state: ServingDep,
    mode: Annotated[Mode | None, Query(description="Instead of the body's `mode`.")] = None,
    include: Annotated[list[Include] | None, Query(description="Optional outputs.")] = None,
    euler_convention: Annotated[EulerConvention | None, Query()] = None,
) -> Response:
    content_type = _media_type(request.headers.get("content-type"))
    if content_type not in ("", col.JSON, col.NPZ) and not content_type.endswith("+json"):
        raise ServiceError(415, "unsupported_media_type", f"Content-Type {content_type!r}; "
                           f"send {col.JSON} or {col.NPZ}")
    answer_type = _response_type(request.headers.get("accept"))
    body = await request.body()  # read in full by the BodyReader middleware
    lease = request.scope[LEASE]  # released by the BodyReader once the answer is sent
    query = {"mode": mode, "include": include, "euler_convention": euler_convention}
    settings = runtime.settings
    async with Work(runtime, request.receive) as work:  # deadline, disconnect, lanes
        parsed = await work.run(steps.parse_cost(body), steps.parse, body,
                                content_type == col.NPZ, query, settings, lease)
        admitted = await work.run(parsed.rows, steps.validate, parsed, state, settings, lease)
        if admitted.plan is not None:  # compound rows: the broadphase counts their work
            admitted = await work.run(admitted.work, steps.count, admitted, settings, lease)
        kind, answer = await work.run(admitted.work, steps.solve, admitted, state, runtime,
                                      answer_type, lease)
    headers = {"X-Model-Version": state.model_version}
    if kind == "bytes":
        return Response(answer, media_type=answer_type, headers=headers)
    pieces = {"box_json": json_pieces, "compound_json": compound_encode.json_pieces,
              "compound_npz": compound_encode.npz_pieces}[kind]
    return StreamedAnswer(pieces(answer, admitted.mode, state.model_version), headers,
                          settings.send_timeout_s, answer_type)
