"""The API's response schemas (pydantic v2), for the answers and the OpenAPI document; the
requests' wire format is :mod:`impactnet.service.codecs.requests` and the contact answers'
models :mod:`impactnet.service.api.answer_schemas` (both re-exported here)."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from impactnet.service.api.answer_schemas import (  # noqa: F401 - the answers' models
    BatchResponse,
    ContactResponse,
)
from impactnet.service.codecs.requests import (  # noqa: F401 - the OpenAPI document's
    BatchOptions,
    BatchRequest,
    Body,
    ContactRequest,
    EulerConvention,
    Include,
    Mode,
    ReloadRequest,
)


class ErrorItem(BaseModel):
    field: str = Field(description='Offending field, e.g. "a.quaternion", "b_size", "body".')
    reason: str
    type: str
    loc: list[str | int]
    rows: list[int] | None = Field(None, description="Batch rows at fault (first 20).")


class ErrorResponse(BaseModel):
    error: str = Field(description="invalid_input, unsupported_pair, body_too_large, "
                       "batch_too_large, too_many_candidates, too_many_part_contacts, "
                       "geometry_too_large, deadline_exceeded, "
                       "body_timeout, mode_unavailable, not_ready, overloaded, "
                       "unsupported_media_type, not_acceptable, not_found, "
                       "method_not_allowed, unauthorized, forbidden, reload_failed, "
                       "internal_error.")
    message: str
    detail: list[ErrorItem] = []
    request_id: str | None = None
    mode: str | None = Field(None, description="The mode at fault (mode_unavailable, "
                             "unsupported_pair).")
    limit: str | None = Field(None, description="The limit at fault (a setting named in GET "
                              "/v1/models `limits`): 413 refusals and 504 "
                              "deadline_exceeded.")
    step: str | None = Field(None, description="reload_failed: the step that failed "
                             "(resolve, read, scene_hash, build, smoke, warm_up, install).")
    bundle: str | None = Field(None, description="reload_failed: the bundle folder tried.")
    model_version: str | None = Field(None, description="reload_failed: the version that "
                                      "keeps serving.")
    new_path: str | None = Field(None, description="moved (410): the path that replaced this "
                                 "one.")


class ReloadResponse(BaseModel):
    reloaded: Literal[True]
    model_version: str = Field(description="The new bundle's version, now serving.")
    previous_model_version: str | None
    bundle: str | None = Field(description="Absolute path of the bundle now serving.")
    store_version: str | None = Field(None, description="The version folder read, where "
                                      "`bundle` is a store (its `current` then).")
    modes: list[Mode]
    default_mode: Mode
    smoke: dict | None = Field(description="The smoke test's figures per pair and mode.")
    seconds: float


class ModesInfo(BaseModel):
    available: list[Mode]
    unavailable: dict[str, str] = Field(description="mode -> why it cannot answer.")
    default: Mode = Field(description="Mode of requests that name none: auto with a bundle, "
                          "exact without, unless configured.")


class PointRule(BaseModel):
    """The rule that defines `point`, and its version (bumped whenever the rule changes)."""

    rule: str = Field(description='"centre-of-pressure": the centre of pressure of the contact '
                      "region under a pressure proportional to the local penetration depth, on "
                      "the mid-surface; it need not lie inside the hull of the manifold's "
                      "points. Version 1 was the depth-weighted mean of the manifold.")
    version: int


class Conventions(BaseModel):
    """What the numbers of an answer mean."""

    point: PointRule
    normal: str = Field(description="Direction of `normal`: from A towards B (the force on B "
                        "acts along +normal).")
    units: str = Field(description="Units of lengths and angles.")


class ModelsResponse(BaseModel):
    model_version: str
    conventions: Conventions
    modes: ModesInfo
    scene: dict | None = Field(description="name, hash, objects (box bodies: name -> size), "
                               "compound_objects (names), pairs, and bodies: name -> {kind "
                               "(box | compound), description; a box's size; a compound "
                               "body's envelope {lo, hi}, origin, made_by (generator and "
                               "detail) and parts [{name, group, kind, lo, hi}] in the body's "
                               "frame}; null when no scene is loaded.")
    bundle: dict | None = Field(description="The learned bundle: name (its folder), version, "
                                "scene (name, "
                                "hash), created_utc, files (SHA-256), pairs (sizes, modes, "
                                "validation metrics, auto thresholds), scene pairs covered and "
                                "not, the smoke test's figures; null while none is loaded.")
    versions: dict[str, str]
    limits: dict[str, int | float]
    contact_types: list[str]
    feature_names: dict[str, str]
    includes: list[str] = Field(description="Accepted values of `include`.")
    loaded_at: float
    replica: str = Field(description="This replica's name (also the `X-Replica` header).")
    store: dict | None = Field(None, description="The bundle store this replica follows: "
                               "`path`, `poll_s`, `current` (what its pointer named at the "
                               "last poll), `served` (the store version serving), `in_sync`, "
                               "`last_follow` (time, version, result, step, error), `failures` "
                               "and `retry_at` of a failing version; null when no store is "
                               "followed.")


class HealthResponse(BaseModel):
    status: Literal["ok"]


class ReadyResponse(BaseModel):
    ready: bool
    reason: str | None = None
    model_version: str | None = None


