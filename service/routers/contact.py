"""POST /v1/contact: one pair."""
from __future__ import annotations

import orjson
from fastapi import APIRouter, Request
from starlette.responses import Response

from service.deps import RuntimeDep, ServingDep
from service.errors import InputError, validated_json
from service.pairs import PAPER_ANGLES_AVAILABLE, contact_json, predict_checked, single_pair
from service.routers import ERRORS
from service.schemas import ContactRequest, ContactResponse

router = APIRouter(tags=["contact"])


def parse_body(raw: bytes, content_type: str | None) -> ContactRequest:
    """The request, parsed and validated in one pass (:func:`service.errors.validated_json`)."""
    return validated_json(ContactRequest, raw, content_type)


_REQUEST_BODY = {"required": True, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/ContactRequest"}}}}


@router.post("/v1/contact", response_model=None, openapi_extra={"requestBody": _REQUEST_BODY},
             responses={200: {"model": ContactResponse},
                        415: {"description": "Content-Type is not JSON."}, **ERRORS},
             summary="Contact of one box pair")
async def contact(request: Request, runtime: RuntimeDep, state: ServingDep) -> Response:
    """Impact point, normal (from A towards B), depth, contact type and features of one pair.

    A body gives `size` or a scene `object`, a `position`, and exactly one of `quaternion`
    ([w, x, y, z]), `matrix` (3x3 rows) or `euler` (radians, `euler_convention`). Units:
    metres, radians. Runs inline on the event loop (a single exact pair takes ~50 us).
    """
    body = parse_body(await request.body(), request.headers.get("content-type"))
    mode = body.mode or state.default_mode
    predictor = state.predictor(mode)
    if "paper_angles" in body.include and not PAPER_ANGLES_AVAILABLE:
        raise InputError("include", "paper_angles is not available in this build")
    pairs = single_pair(body, state.scene)
    contacts = predict_checked(predictor, pairs)
    runtime.metrics.record_predictions(mode, {str(contacts.predictor[0]): 1})
    answer = contact_json(contacts, pairs, mode, state.model_version, body.include)
    return Response(orjson.dumps(answer), media_type="application/json",
                    headers={"X-Model-Version": state.model_version})
