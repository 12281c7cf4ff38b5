"""POST /v1/contact/batch: N pairs, columnar JSON or npz in and out."""
from __future__ import annotations

import asyncio
import contextvars
from typing import Annotated

import numpy as np
import orjson
from fastapi import APIRouter, Query, Request
from pydantic import ValidationError
from starlette.responses import Response

from impactnet.service.api.deps import RuntimeDep, ServingDep
from impactnet.service.api.errors import InputError, ServiceError, validation_items
from impactnet.service.api.routers import ERRORS
from impactnet.service.api.schemas import (
    BatchOptions,
    BatchResponse,
    EulerConvention,
    Include,
    Mode,
)
from impactnet.service.batch_solve import PAIR_INPUT_BYTES, solve_batch
from impactnet.service.codecs import columns as col
from impactnet.service.codecs.answer_encode import (
    STREAM_ROWS,
    StreamedJSON,
    encode_json,
    encode_npz,
    json_pieces,
)
from impactnet.service.codecs.batch_json import parse_json_batch
from impactnet.service.codecs.npz import parse_npz
from impactnet.service.compound_solve import (
    batch_json,
    batch_npz,
    names_compound,
    solve_compound,
)
from impactnet.service.limits.body import LEASE
from impactnet.service.limits.budget import Lease
from impactnet.service.predictors import ServingState
from impactnet.service.runtime import Runtime

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


def _options(query: dict, body: dict) -> BatchOptions:
    both = sorted(k for k in body if query.get(k) not in (None, []))
    if both:
        raise InputError(both[0], "given both in the query string and in the body")
    merged = {**{k: v for k, v in query.items() if v not in (None, [])}, **body}
    try:
        return BatchOptions.model_validate(merged)
    except ValidationError as exc:
        first = validation_items(exc.errors())[0]
        raise InputError(first["field"], first["reason"], type_=first["type"]) from exc


def _rows(columns: dict) -> int:
    """Pairs of a batch: the longest per-pair column (1 if every column is one value)."""
    rows = 1
    for name, value in columns.items():
        if name not in col.COLUMNS or not isinstance(value, np.ndarray):
            continue  # refused by the validation that follows
        tail = col.tail_of(name) or ()
        if value.ndim == len(tail) + 1:
            rows = max(rows, len(value))
    return rows


def _score(body: bytes, binary_in: bool, answer_type: str, query: dict, state: ServingState,
           runtime: Runtime, lease: Lease):
    """The answer: npz or small JSON as bytes, large JSON as the arrays to stream. Runs in a
    batch worker thread; every step reserves its memory in ``lease`` first."""
    settings = runtime.settings
    if binary_in:
        columns, body_options = parse_npz(body, settings.max_body_bytes,
                                          settings.max_batch_pairs, lease), {}
    else:
        columns, body_options = parse_json_batch(body, settings.max_batch_pairs, lease)
    options = _options(query, body_options)
    mode = options.mode or state.default_mode
    lease.reserve(min(_rows(columns), settings.max_batch_pairs) * PAIR_INPUT_BYTES,
                  "validating the batch")
    pairs = col.batch_pairs(columns, state.scene.with_compound, options.euler_convention,
                            settings.max_batch_pairs)
    del columns
    if names_compound(pairs, state.scene):  # the oracle, or the pair's learned chain
        arrays = solve_compound(pairs, state.scene, settings.max_part_contacts_per_pose,
                                settings.max_part_contacts_per_batch, state.compound, mode)
        names, counts = np.unique(arrays["predictor"], return_counts=True)
        runtime.metrics.record_predictions(mode, dict(zip(names.tolist(), counts.tolist(),
                                                          strict=True)))
        if answer_type == col.NPZ:
            return batch_npz(arrays, mode, state.model_version), mode
        return orjson.dumps(batch_json(arrays, mode, state.model_version)), mode
    arrays = solve_batch(state.predictor(mode), pairs, options.include, lease)
    counts = np.bincount(arrays["predictor_code"], minlength=len(arrays["predictor_names"]))
    runtime.metrics.record_predictions(mode, dict(zip(arrays["predictor_names"].tolist(),
                                                      counts.tolist(), strict=True)))
    runtime.metrics.batch_size.observe(len(pairs))
    if answer_type == col.NPZ:
        lease.reserve(2 * sum(a.nbytes for a in arrays.values()), "encoding the npz answer")
        return encode_npz(arrays, mode, state.model_version), mode
    if len(pairs) <= STREAM_ROWS:
        return encode_json(arrays, mode, state.model_version), mode
    return arrays, mode


async def _in_batch_worker(runtime: Runtime, *args):
    """``_score(*args)`` in the runtime's batch pool (``max_batch_workers`` at a time), with
    the request's context (its request id) carried over."""
    context = contextvars.copy_context()
    loop = asyncio.get_running_loop()
    return await loop.run_in_executor(runtime.batch_pool, context.run, _score, *args)


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
    answer, mode_used = await _in_batch_worker(runtime, body, content_type == col.NPZ,
                                               answer_type, query, state, runtime, lease)
    headers = {"X-Model-Version": state.model_version}
    if isinstance(answer, bytes):
        return Response(answer, media_type=answer_type, headers=headers)
    return StreamedJSON(json_pieces(answer, mode_used, state.model_version), headers,
                        runtime.settings.send_timeout_s)
