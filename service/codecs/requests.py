"""The requests' wire format (pydantic v2): a pair, a batch's options, a frame.

Numbers are strict: a JSON string ("1.0", "NaN") is not a number, NaN and +-Infinity are
rejected (``allow_inf_nan=False``), unknown keys are rejected. Coordinates and sizes are
bounded to the range the exact solver is tested on (:data:`POSITION_MAX_M`,
:data:`SIZE_MIN_M`, :data:`SIZE_MAX_M`), so every accepted input has a finite answer.

The batch endpoint parses its columns with NumPy (:mod:`impactnet.service.codecs.columns`), not
with these models: :class:`BatchRequest` documents its JSON body in the OpenAPI schema and is
checked against that parser by the tests. The API's response models live in
:mod:`impactnet.service.api.schemas`.
"""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

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

Coordinate = Annotated[float, Field(ge=-POSITION_MAX_M, le=POSITION_MAX_M)]
Edge = Annotated[float, Field(ge=SIZE_MIN_M, le=SIZE_MAX_M)]
Component = Annotated[float, Field(ge=-ANGLE_MAX, le=ANGLE_MAX)]
Vec3 = Annotated[list[Coordinate], Field(min_length=3, max_length=3)]
Size3 = Annotated[list[Edge], Field(min_length=3, max_length=3)]
Quaternion = Annotated[list[Component], Field(min_length=4, max_length=4)]
Euler = Annotated[list[Component], Field(min_length=3, max_length=3)]
#: Largest margin of a request (metres): the gap before contact is asked for pairs closer than
#: it; far more than a crane's approach needs, small against the scene.
MARGIN_MAX_M = 100.0
Margin = Annotated[float, Field(ge=0.0, le=MARGIN_MAX_M)]
MatrixRow = Annotated[list[Component], Field(min_length=3, max_length=3)]
Matrix = Annotated[list[MatrixRow], Field(min_length=3, max_length=3)]
ObjectName = Annotated[str, Field(min_length=1, max_length=OBJECT_NAME_MAX)]

_STRICT = ConfigDict(strict=True, allow_inf_nan=False, extra="forbid")
_ORIENTATIONS = ("quaternion", "matrix", "euler")


class Body(BaseModel):
    """One body: a scene object, a raw size (a box) or inline parts, a position, exactly one
    orientation."""

    model_config = _STRICT

    object: ObjectName | None = Field(None, description="Name of a body of the served scene "
                                      "(GET /v1/models lists them); instead of `size`.")
    parts: Annotated[list[dict], Field(min_length=1, max_length=MAX_INLINE_PARTS)] | None = Field(
        None, json_schema_extra={"x-max-keys-per-item": PART_KEYS_MAX},
        description="A compound body given inline (single pairs and frames), in the scene "
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
        default_factory=list, description="Optional outputs: `manifold` (each part contact's "
        "polygon), `paper_angles` (the paper's four spherical angles).")
    euler_convention: EulerConvention = "zyx"
    margin: Margin = Field(0.0, description="Metres: a pair apart by less answers its gap "
                           "(`distance` > 0) and the closest points; 0: contacts only.")


def _column(doc: str):
    return Field(None, description=doc + " One value for every pair, or an array of N.")


class BatchRequest(BaseModel):
    """Columnar batch of N pairs (JSON body of POST /v2/contact/batch).

    Every column holds either one value (broadcast to all pairs) or an array of N values;
    all arrays must have the same N. Per body: exactly one of `*_object` / `*_size`, and
    exactly one of `*_quaternion` / `*_matrix` / `*_euler`.
    """

    model_config = _STRICT

    mode: Mode | None = None
    include: Annotated[list[Include], Field(max_length=2)] = Field(default_factory=list)
    euler_convention: EulerConvention = "zyx"
    margin: Margin = Field(0.0, description="Metres: pairs apart by less answer their gap "
                           "(`distance` > 0) and the closest points; 0: contacts only.")
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


class BatchOptions(BaseModel):
    """Options of a batch: JSON body fields, or query parameters (any content type)."""

    model_config = _STRICT

    mode: Mode | None = None
    include: Annotated[list[Include], Field(max_length=2)] = Field(default_factory=list)
    euler_convention: EulerConvention = "zyx"
    margin: Margin = 0.0


class ReloadRequest(BaseModel):
    """Body of POST /v1/admin/reload; an empty body or ``{}`` re-reads the configured path."""

    model_config = _STRICT

    bundle: Annotated[str, Field(min_length=1, max_length=4096)] | None = Field(
        None, description="Bundle folder on the server (relative: from the server's working "
        "directory). Default: the configured one (--bundle, else models/bundles/<scene>).")


#: A body's id in a frame: letters, digits and ``_ . : -``, as a simulator names its bodies.
BodyId = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.:\-]+$")]
#: Bits of a contact filter mask (MuJoCo's contype / conaffinity are 32-bit).
FilterMask = Annotated[int, Field(ge=0, le=2**32 - 1)]
#: Most bodies a frame's JSON may list (the setting `max_frame_bodies` may allow fewer).
MAX_FRAME_BODIES = 100_000
#: A registered world's name: ``w-`` and the hex digest of its bodies.
WorldName = Annotated[str, Field(min_length=3, max_length=70, pattern=r"^w-[0-9a-f]+$")]


class FrameBody(Body):
    """One body of a frame: a pair's body with an ``id`` and, optionally, its contact filter."""

    id: BodyId = Field(description="The body's id, unique in the frame and its world.")
    contype: FilterMask | None = Field(None, description="Filter bits (MuJoCo's contype); "
                                       "default 1. Two bodies may touch when (contype_a & "
                                       "conaffinity_b) | (contype_b & conaffinity_a) != 0.")
    conaffinity: FilterMask | None = Field(None, description="Filter bits (MuJoCo's "
                                           "conaffinity); default 1.")


FrameBodies = Annotated[list[FrameBody], Field(min_length=1, max_length=MAX_FRAME_BODIES)]


class WorldRequest(BaseModel):
    """Body of POST /v2/worlds: the static bodies of a world, registered once."""

    model_config = _STRICT

    bodies: FrameBodies
    euler_convention: EulerConvention = "zyx"


class FrameOptions(BaseModel):
    """What a frame answers (POST /v2/frame: JSON body fields, or query parameters of an npz
    frame)."""

    model_config = _STRICT

    world: WorldName | None = Field(None, description="A world registered with POST "
                                    "/v2/worlds: its bodies join the frame as static ones "
                                    "(two of them are never paired). 409 `unknown_world` when "
                                    "this replica does not hold it: register it again.")
    margin: Margin = Field(0.0, description="Metres: pairs apart by less are answered with "
                           "their gap; 0: contacts only.")
    pairs: Literal["all", "scene"] = Field("all", description="`scene`: only the pairs of "
                                           "scene objects that the scene lists (and every "
                                           "pair with a raw `size` or inline `parts` body).")
    mode: Mode | None = None
    include: Annotated[list[Include], Field(max_length=2)] = Field(default_factory=list)
    euler_convention: EulerConvention = "zyx"


class FrameRequest(FrameOptions):
    """Body of POST /v2/frame: the bodies of one frame (those that moved, when ``world``
    names a registered world), and what to answer."""

    bodies: Annotated[list[FrameBody], Field(max_length=MAX_FRAME_BODIES)]
