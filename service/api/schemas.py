"""Request and response schemas of the HTTP API (pydantic v2), apart from the logic.

Numbers are strict: a JSON string ("1.0", "NaN") is not a number, NaN and +-Infinity are
rejected (``allow_inf_nan=False``), unknown keys are rejected. Coordinates and sizes are
bounded to the range the exact solver is tested on (:data:`POSITION_MAX_M`,
:data:`SIZE_MIN_M`, :data:`SIZE_MAX_M`), so every accepted input has a finite answer.

The batch endpoint parses its columns with NumPy (:mod:`impactnet.service.codecs.columns`), not with
these
models: :class:`BatchRequest` documents its JSON body in the OpenAPI schema and is checked
against that parser by the tests.
"""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.domain import (  # the solver's input domain
    POSITION_MAX_M,
    SIZE_MAX_M,
    SIZE_MIN_M,
)

#: Largest accepted |component| of a quaternion / Euler angle (radians); quaternions are
#: normalised, so the scale carries no meaning, but it must not overflow.
ANGLE_MAX = 1e6
#: Longest scene object name.
OBJECT_NAME_MAX = 64
#: Most parts of a compound body given inline in a request (the setting `max_inline_parts`
#: may set fewer).
MAX_INLINE_PARTS = 128
#: Most keys of one inline part, nested tables included: `name`, one shape, and the largest
#: shape table's keys (a frustum's sides, base, tip_scale, height, centre).
PART_KEYS_MAX = 7

Mode = Literal["exact", "single", "committee", "auto"]
Include = Literal["manifold", "paper_angles"]
EulerConvention = Literal["zyx", "xyz"]
ContactType = Literal[CONTACT_TYPES]  # type: ignore[valid-type]

Coordinate = Annotated[float, Field(ge=-POSITION_MAX_M, le=POSITION_MAX_M)]
Edge = Annotated[float, Field(ge=SIZE_MIN_M, le=SIZE_MAX_M)]
Component = Annotated[float, Field(ge=-ANGLE_MAX, le=ANGLE_MAX)]
Vec3 = Annotated[list[Coordinate], Field(min_length=3, max_length=3)]
Size3 = Annotated[list[Edge], Field(min_length=3, max_length=3)]
Quaternion = Annotated[list[Component], Field(min_length=4, max_length=4)]
Euler = Annotated[list[Component], Field(min_length=3, max_length=3)]
MatrixRow = Annotated[list[Component], Field(min_length=3, max_length=3)]
Matrix = Annotated[list[MatrixRow], Field(min_length=3, max_length=3)]
ObjectName = Annotated[str, Field(min_length=1, max_length=OBJECT_NAME_MAX)]

_STRICT = ConfigDict(strict=True, allow_inf_nan=False, extra="forbid")
_ORIENTATIONS = ("quaternion", "matrix", "euler")


class Body(BaseModel):
    """One box: a scene object or a raw size, a position, exactly one orientation."""

    model_config = _STRICT

    object: ObjectName | None = Field(None, description="Name of a body of the served scene "
                                      "(GET /v1/models lists them); instead of `size`.")
    parts: Annotated[list[dict], Field(min_length=1, max_length=MAX_INLINE_PARTS)] | None = Field(
        None, json_schema_extra={"x-max-keys-per-item": PART_KEYS_MAX},
        description="A compound body given inline (POST /v1/contact only), in the scene "
        "files' part format: each `{name, box: {size, centre}}`, `{name, points: [[x, y, z], "
        "...]}`, `{name, frustum: {sides, base, tip_scale, height, centre}}` or `{name, mesh: "
        "{format: stl|obj|glb, data: <base64>}}`; instead of `size` / `object`.")
    size: Size3 | None = Field(None, description="Full edge lengths [lx, ly, lz], metres.")
    position: Vec3 = Field(description="Centre in the world frame, metres.")
    quaternion: Quaternion | None = Field(None, description="[w, x, y, z], normalised here.")
    matrix: Matrix | None = Field(None, description="3x3 rotation matrix, rows "
                                  "(v_world = R v_body); max |R^T R - I| <= 1e-6, det > 0.")
    euler: Euler | None = Field(None, description="Radians; convention `euler_convention` "
                                "(zyx: [roll, pitch, yaw], R = Rz(yaw) Ry(pitch) Rx(roll)).")

    @model_validator(mode="after")
    def _exactly_one(self) -> Body:
        if sum(v is not None for v in (self.object, self.size, self.parts)) != 1:
            raise ValueError("give exactly one of `object`, `size` and `parts`")
        given = [n for n in _ORIENTATIONS if getattr(self, n) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one orientation of `quaternion`, `matrix`, "
                             f"`euler` (got {', '.join(given) or 'none'})")
        return self


class ContactRequest(BaseModel):
    """One pair."""

    model_config = _STRICT

    a: Body
    b: Body
    mode: Mode | None = Field(None, description="Predictor: exact (always served), single, "
                              "committee, auto. Default: the server's default mode.")
    include: Annotated[list[Include], Field(max_length=2)] = Field(
        default_factory=list, description="Optional outputs: `manifold` (contact polygon), "
        "`paper_angles` (the paper's four spherical angles).")
    euler_convention: EulerConvention = "zyx"


class Feature(BaseModel):
    id: int = Field(description="Unified feature id: faces 0-5, edges 6-17, vertices 18-25, "
                    "-1 none.")
    name: str = Field(description='e.g. "face +z", "edge x(+y,-z)", "vertex (+,-,+)".')
    kind: Literal["face", "edge", "vertex", "none"]


class Manifold(BaseModel):
    """The incident face's clip against the reference face (edge-edge: the one point)."""

    count: int = Field(description="Number of contact points (0 when separated).")
    points: list[list[float]] = Field(description="(count, 3) world frame, metres, on the "
                                      "mid-surface, the deepest first.")
    depths: list[float] = Field(description="(count,) penetration of each point, metres, "
                                ">= 0, the deepest first.")


class PaperAngles(BaseModel):
    """The paper's outputs, in A's frame, radians; null where undefined (no contact)."""

    point_azimuth: float | None
    point_elevation: float | None
    force_azimuth: float | None
    force_elevation: float | None


class ContactResponse(BaseModel):
    colliding: bool
    point: list[float] = Field(description="Impact point, world frame, metres: the centre of "
                               "pressure of the contact region (pressure proportional to the "
                               "local depth), on the mid-surface; it need not lie inside the "
                               "hull of the manifold's points (GET /v1/models: conventions).")
    normal: list[float] = Field(description="Unit normal from A towards B (force on B along "
                                "+normal).")
    depth: float = Field(description="Penetration along the normal, metres, >= 0.")
    contact_type: ContactType
    feature_a: Feature
    feature_b: Feature
    axis: int = Field(description="Separating-axis index: 0-2 faces of A, 3-5 faces of B, "
                      "6 + 3i + j edge i of A x edge j of B.")
    confidence: float = Field(description="1 for exact; a learned predictor's confidence in "
                              "[0, 1] (committee: 1, 0 outside the trained depth range).")
    predictor: str = Field(description="The predictor that answered: exact, single, "
                           "committee (in mode auto: committee, or exact for a fallback).")
    mode: Mode = Field(description="The mode that was requested (or the default).")
    model_version: str
    manifold: Manifold | None = Field(None, description="Only with include=manifold.")
    paper_angles: PaperAngles | None = Field(None, description="Only with "
                                             "include=paper_angles.")


def _column(doc: str):
    return Field(None, description=doc + " One value for every pair, or an array of N.")


class BatchRequest(BaseModel):
    """Columnar batch of N pairs (JSON body of POST /v1/contact/batch).

    Every column holds either one value (broadcast to all pairs) or an array of N values;
    all arrays must have the same N. Per body: exactly one of `*_object` / `*_size`, and
    exactly one of `*_quaternion` / `*_matrix` / `*_euler`.
    """

    model_config = _STRICT

    mode: Mode | None = None
    include: Annotated[list[Include], Field(max_length=2)] = Field(default_factory=list)
    euler_convention: EulerConvention = "zyx"
    a_object: ObjectName | list[ObjectName] | None = _column("Scene object names of A.")
    a_size: Size3 | list[Size3] | None = _column("Sizes of A, metres.")
    a_position: Vec3 | list[Vec3] = Field(description="Centres of A, metres. One value for "
                                          "every pair, or an array of N.")
    a_quaternion: Quaternion | list[Quaternion] | None = _column("Orientations of A.")
    a_matrix: Matrix | list[Matrix] | None = _column("Rotation matrices of A (rows).")
    a_euler: Euler | list[Euler] | None = _column("Euler angles of A, radians.")
    b_object: ObjectName | list[ObjectName] | None = _column("Scene object names of B.")
    b_size: Size3 | list[Size3] | None = _column("Sizes of B, metres.")
    b_position: Vec3 | list[Vec3] = Field(description="Centres of B, metres. One value for "
                                          "every pair, or an array of N.")
    b_quaternion: Quaternion | list[Quaternion] | None = _column("Orientations of B.")
    b_matrix: Matrix | list[Matrix] | None = _column("Rotation matrices of B (rows).")
    b_euler: Euler | list[Euler] | None = _column("Euler angles of B, radians.")


class BatchResponse(BaseModel):
    """Columnar answer: every column has N entries, row i answers pair i."""

    n: int
    mode: Mode
    model_version: str
    predictor: list[str]
    colliding: list[bool]
    point: list[list[float]]
    normal: list[list[float]]
    depth: list[float]
    contact_type: list[ContactType]
    feature_a: list[int]
    feature_b: list[int]
    axis: list[int]
    confidence: list[float]
    manifold_count: list[int] | None = Field(None, description="Only with include=manifold.")
    manifold_points: list[list[list[float]]] | None = Field(
        None, description="(N, 8, 3), rows past manifold_count are 0.")
    manifold_depths: list[list[float]] | None = Field(None, description="(N, 8).")
    paper_angles: list[list[float | None]] | None = Field(
        None, description="(N, 4) [point azimuth, point elevation, force azimuth, force "
        "elevation], A's frame, radians; null rows where there is no contact.")


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


class ReloadRequest(BaseModel):
    """Body of POST /v1/admin/reload; an empty body or ``{}`` re-reads the configured path."""

    model_config = _STRICT

    bundle: Annotated[str, Field(min_length=1, max_length=4096)] | None = Field(
        None, description="Bundle folder on the server (relative: from the server's working "
        "directory). Default: the configured one (--bundle, else models/bundles/<scene>).")


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


class BatchOptions(BaseModel):
    """Options of a batch: JSON body fields, or query parameters (any content type)."""

    model_config = _STRICT

    mode: Mode | None = None
    include: Annotated[list[Include], Field(max_length=2)] = Field(default_factory=list)
    euler_convention: EulerConvention = "zyx"
