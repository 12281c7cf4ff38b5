"""POST /v2/contact/batch: N pairs, columnar JSON or npz in and out, in the one answer shape."""
from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request
from starlette.responses import Response

from impactnet.service import batch_steps as steps
from impactnet.service.api.deps import RuntimeDep, ServingDep
from impactnet.service.api.routers import ERRORS, MOVED
from impactnet.service.api.schemas import BatchResponse, EulerConvention, Include, Mode
from impactnet.service.codecs import columns as col
from impactnet.service.codecs.answers import batch_json, batch_npz
from impactnet.service.codecs.stream import answer_response
from impactnet.service.errors import ServiceError
from impactnet.service.limits.body import LEASE
from impactnet.service.limits.lanes import Work
from impactnet.service.solve import solve

router = APIRouter(tags=["contact"])

LAYOUT = """
**Binary layout** (`Content-Type: application/x-npz` request, `Accept: application/x-npz`
answer; either may be JSON while the other is npz). A NumPy `.npz` archive (zip of `.npy`
members, as written by `numpy.savez`; deflated members are accepted), read with
`allow_pickle=False`: object arrays are refused. Request members are the JSON columns
(`a_size`, `a_object`, `a_position`, `a_quaternion` | `a_matrix` | `a_euler`, same for `b_`),
numbers of any integer or float dtype (converted to float64), names as unicode (`<U`) arrays;
options go in the query string (`?mode=exact&include=manifold&margin=0.5`).

**The answer** (JSON and npz carry the same members): per pair `colliding`, `point`, `normal`,
`depth`, `distance`, `contact_type`, `feature_a` and `feature_b` (`part`, `id`, `name`,
`kind`), `predictor`, `confidence`, `cluster_size` (and `paper_angles` with
include=paper_angles); per part contact, in a ragged layout, `contacts` = {`offsets` (N + 1;
pair i's contacts at `offsets[i]:offsets[i+1]`, the deepest first), `part_a`, `part_b`,
`point`, `normal`, `depth`, `contact_type`, `feature_a` and `feature_b` (`id`, `name`,
`kind`), `axis`, `pressure` (and the manifold with include=manifold)}, and `n`, `mode`,
`model_version`. npz members are named by their path (`feature_a_name`, `contact_offsets`,
`contact_feature_b_kind`); JSON's nulls (a distance beyond the margin, angles without contact)
are inf and NaN in npz. Caps: `max_candidates_per_pose`, `max_candidates_per_request` (413
`too_many_candidates`), `max_shape_pairs_per_request` (413 `too_many_shape_pairs`),
`max_part_contacts_per_pose`, `max_part_contacts_per_batch` (413
`too_many_part_contacts`), each named by the error's `limit`.
"""

_REQUEST_BODY = {
    "required": True,
    "content": {
        col.JSON: {"schema": {"$ref": "#/components/schemas/BatchRequest"}},
        col.NPZ: {"schema": {"type": "string", "format": "binary"}},
    },
}


def media_type(value: str | None) -> str:
    return (value or "").split(";", 1)[0].strip().lower()


def response_type(accept: str | None) -> str:
    """npz when the client accepts it, JSON when it accepts JSON or anything; else 406."""
    kinds = {media_type(part) for part in (accept or "*/*").split(",")}
    if col.NPZ in kinds:
        return col.NPZ
    if kinds & {col.JSON, "*/*", "application/*", ""} or any(k.endswith("+json") for k in kinds):
        return col.JSON
    raise ServiceError(406, "not_acceptable", f"cannot answer as {accept!r}; accepted: "
                       f"{col.JSON}, {col.NPZ}")


@router.post(
    "/v2/contact/batch", response_model=None, summary="Contacts of N pairs of bodies",
    openapi_extra={"requestBody": _REQUEST_BODY},
    responses={200: {"model": BatchResponse, "content": {
        col.NPZ: {"schema": {"type": "string", "format": "binary"}}}},
        406: {"description": "Accept names neither JSON nor npz."},
        415: {"description": "Content-Type is neither JSON nor npz."}, **ERRORS},
    description="Columnar batch: every column holds one value (broadcast) or an array of N; "
    "the answer has one entry per pair in every column, and the part contacts of every pair. "
    "Validation, scoring and encoding are vectorised (no Python loop over pairs) and run in "
    "worker threads chosen by the work's cost (small work never waits behind large work). "
    "Limits: JSON bodies up to `max_json_body_bytes` (32 MiB: 100,000 pairs with "
    "quaternions), npz up to `max_body_bytes`, `max_batch_pairs` pairs; a batch is counted "
    "and reserves its memory in the server's budget before it is solved (503 `overloaded` "
    "with Retry-After when there is no room now, 413 when it could never fit); it stops at "
    "`compute_deadline_s` (504). A JSON object that repeats a key is 422. Large answers are "
    "streamed (chunked).\n" + LAYOUT)
async def batch(
    request: Request, runtime: RuntimeDep, state: ServingDep,
    mode: Annotated[Mode | None, Query(description="Instead of the body's `mode`.")] = None,
    include: Annotated[list[Include] | None, Query(description="Optional outputs.")] = None,
    euler_convention: Annotated[EulerConvention | None, Query()] = None,
    margin: Annotated[float | None, Query(description="Metres: pairs apart by less answer "
                                          "their gap.")] = None,
) -> Response:
    content_type = media_type(request.headers.get("content-type"))
    if content_type not in ("", col.JSON, col.NPZ) and not content_type.endswith("+json"):
        raise ServiceError(415, "unsupported_media_type", f"Content-Type {content_type!r}; "
                           f"send {col.JSON} or {col.NPZ}")
    answer_type = response_type(request.headers.get("accept"))
    body = await request.body()  # read in full by the BodyReader middleware
    lease = request.scope[LEASE]  # released by the BodyReader once the answer is sent
    query = {"mode": mode, "include": include, "euler_convention": euler_convention,
             "margin": margin}
    settings = runtime.settings
    async with Work(runtime, request.receive) as work:  # deadline, disconnect, lanes
        parsed = await work.run(steps.parse_cost(body), steps.parse, body,
                                content_type == col.NPZ, query, settings, lease)
        pairs = await work.run(parsed.rows, steps.validate, parsed, state.scene, settings,
                               lease)
        options = parsed.options
        chosen = options.mode or state.default_mode
        answers = await solve(work, state, pairs, chosen, options.include, options.margin,
                              lease)
        runtime.metrics.record_answers(chosen, answers)
        encode = batch_npz if answer_type == col.NPZ else batch_json
        pieces = encode(answers, pairs, options.include, chosen, state.model_version)
        return await answer_response(work, pieces, answers,
                                     {"X-Model-Version": state.model_version},
                                     settings.send_timeout_s, answer_type)


@router.post("/v1/contact/batch", include_in_schema=False)
async def batch_v1() -> Response:
    """The path of the answer shape before 0.2.0: 410 naming the new one."""
    raise MOVED("/v1/contact/batch", "/v2/contact/batch")
