"""The OpenAPI models of the one answer shape (POST /v2/contact, POST /v2/contact/batch), as
:mod:`impactnet.service.codecs.answers` writes it: the body level (the deepest part contact's
type, features and parts, the distance and the closest points within the margin) and the part
contacts (one for two touching boxes: a box is a body of one part named ``box``).

Every model forbids keys it does not name (``additionalProperties: false``), so that the
document and the answers cannot drift apart unnoticed (tests/service/test_answer_schema.py).
"""
from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from impactnet.models.contacts import CONTACT_TYPES, MAX_MANIFOLD_POINTS
from impactnet.service.codecs.requests import Mode

ContactType = Literal[CONTACT_TYPES]  # type: ignore[valid-type]
FeatureKind = Literal["face", "edge", "vertex", "none"]
#: Number of the paper's angles of a pair.
PAPER_ANGLES = 4
Vector = Annotated[list[float], Field(min_length=3, max_length=3)]
Angles = Annotated[list[float], Field(min_length=PAPER_ANGLES, max_length=PAPER_ANGLES)]
ManifoldPoints = Annotated[list[Vector], Field(min_length=MAX_MANIFOLD_POINTS,
                                               max_length=MAX_MANIFOLD_POINTS)]
ManifoldDepths = Annotated[list[float], Field(min_length=MAX_MANIFOLD_POINTS,
                                              max_length=MAX_MANIFOLD_POINTS)]
_CLOSED = ConfigDict(extra="forbid")

_ID = ("Feature id: a box part's faces 0-5, edges 6-17, vertices 18-25; a convex part's hull "
       "faces, then edges, then vertices; -1 none.")
_NAME = ('e.g. "face +z", "edge x(+y,-z)", "vertex (+,-,+)" (a box part), "face 3" (a convex '
         'part), "none".')
_PART = ("The part of the body that holds the feature (a box's one part: `box`); null where "
         "the pair neither touches nor lies within the margin.")
_DISTANCE = ("-depth in contact; the gap (> 0, metres) for a pair apart by less than the "
             "request's margin; null beyond it.")
_CLOSEST = ("The closest point (the centroid of the closest region) on {side}, world frame, "
            "metres, for a pair apart by less than the margin; null otherwise.")
_AXIS = ("A box pair's separating axis: 0-2 faces of A, 3-5 faces of B, 6 + 3i + j edge i of "
         "A x edge j of B; -1 for a convex part.")
_PRESSURE = ("The pressure integrated over a face contact's region, m^3: the part contact's "
             "weight in the body-level point; 0 for edge-edge contacts and learned answers.")
_CLUSTER = "Part contacts in the cluster of the deepest one (its normal within 10 degrees)."
_PREDICTOR = ("Who answered: exact, single, committee (a box pair), oracle, exact-part, learned "
              "(a compound pair).")


class Feature(BaseModel):
    """A part contact's feature."""

    model_config = _CLOSED
    id: int = Field(description=_ID)
    name: str = Field(description=_NAME)
    kind: FeatureKind


class BodyFeature(Feature):
    """A body's feature at the body level: the deepest part contact's, with its part."""

    part: str | None = Field(description=_PART)


class Manifold(BaseModel):
    """A part contact's polygon: the incident face's clip against the reference face."""

    model_config = _CLOSED
    count: int = Field(description="Number of contact points.")
    points: list[Vector] = Field(description="(count, 3) world frame, metres, the deepest "
                                 "first.")
    depths: list[float] = Field(description="(count,) penetration of each point, metres, >= 0, "
                                "the deepest first.")


class PartContact(BaseModel):
    """One part contact of a pair (a part of A against a part of B)."""

    model_config = _CLOSED
    part_a: str
    part_b: str
    point: Vector = Field(description="Centre of pressure of the part pair's contact region.")
    normal: Vector = Field(description="Unit normal from A's part towards B's.")
    depth: float = Field(description="Penetration along the normal, metres, >= 0.")
    contact_type: ContactType
    feature_a: Feature
    feature_b: Feature
    axis: int = Field(description=_AXIS)
    pressure: float = Field(description=_PRESSURE)
    manifold: Manifold = Field(None, description="Only with include=manifold.")


class PairAnswer(BaseModel):
    """One pair's answer: the body level, then its part contacts (the deepest first); a frame's
    pair carries it as it is, a single answer adds the request's mode and the bundle's
    version."""

    model_config = _CLOSED
    colliding: bool
    point: Vector = Field(description="Impact point, world frame, metres: the centre of "
                          "pressure of the contact region (pressure proportional to the local "
                          "depth), on the mid-surface; it need not lie inside the hull of the "
                          "manifold's points (GET /v1/models: conventions). A pair apart: the "
                          "midpoint between its closest parts.")
    normal: Vector = Field(description="Unit normal from A towards B (force on B along "
                           "+normal); a pair apart: its separating direction.")
    depth: float = Field(description="Penetration along the normal, metres, >= 0.")
    distance: float | None = Field(description=_DISTANCE)
    closest_a: Vector | None = Field(description=_CLOSEST.format(side="A"))
    closest_b: Vector | None = Field(description=_CLOSEST.format(side="B"))
    contact_type: ContactType = Field(description="The deepest part contact's type.")
    feature_a: BodyFeature
    feature_b: BodyFeature
    predictor: str = Field(description=_PREDICTOR)
    confidence: float = Field(description="1 for exact; a learned predictor's confidence in "
                              "[0, 1].")
    cluster_size: int = Field(description=_CLUSTER)
    paper_angles: Angles | None = Field(None, description="Only with include=paper_angles: "
                                        "[point azimuth, point elevation, force azimuth, force "
                                        "elevation], A's frame, radians; null without contact.")
    contacts: list[PartContact] = Field(description="The part contacts, the deepest first "
                                        "(one for two touching boxes).")


class ContactResponse(PairAnswer):
    """POST /v2/contact: one pair's answer, the mode and the bundle's version."""

    mode: Mode = Field(description="The mode that was requested (or the default).")
    model_version: str
    warnings: list[str] = Field(None, description="Notes on inline parts (a mesh replaced by "
                                "its hull); absent when there are none.")


class FeatureColumns(BaseModel):
    """A feature column per key, one row per part contact."""

    model_config = _CLOSED
    id: list[int] = Field(description=_ID)
    name: list[str] = Field(description=_NAME)
    kind: list[FeatureKind]


class BodyFeatureColumns(FeatureColumns):
    """A body-level feature column per key, one row per pair."""

    part: list[str | None] = Field(description=_PART)


class ContactColumns(BaseModel):
    """The part contacts of every pair, ragged: pair i's at ``offsets[i]:offsets[i+1]``."""

    model_config = _CLOSED
    offsets: list[int] = Field(description="N + 1 offsets into the contact columns.")
    part_a: list[str]
    part_b: list[str]
    point: list[Vector]
    normal: list[Vector]
    depth: list[float]
    contact_type: list[ContactType]
    feature_a: FeatureColumns
    feature_b: FeatureColumns
    axis: list[int] = Field(description=_AXIS)
    pressure: list[float] = Field(description=_PRESSURE)
    manifold_count: list[int] = Field(None, description="Only with include=manifold.")
    manifold_points: list[ManifoldPoints] = Field(
        None, description="(M, 8, 3); rows past manifold_count are 0.")
    manifold_depths: list[ManifoldDepths] = Field(None, description="(M, 8).")


class BatchResponse(BaseModel):
    """Columnar answer: every body-level column has N entries, row i answers pair i."""

    model_config = _CLOSED
    n: int
    mode: Mode
    model_version: str
    colliding: list[bool]
    point: list[Vector]
    normal: list[Vector]
    depth: list[float]
    distance: list[float | None] = Field(description=_DISTANCE)
    closest_a: list[Vector | None] = Field(description=_CLOSEST.format(side="A"))
    closest_b: list[Vector | None] = Field(description=_CLOSEST.format(side="B"))
    contact_type: list[ContactType]
    feature_a: BodyFeatureColumns
    feature_b: BodyFeatureColumns
    predictor: list[str] = Field(description=_PREDICTOR)
    confidence: list[float]
    cluster_size: list[int] = Field(description=_CLUSTER)
    paper_angles: list[Angles | None] = Field(
        None, description="Only with include=paper_angles: (N, 4) [point azimuth, point "
        "elevation, force azimuth, force elevation], A's frame, radians; a null row where "
        "there is no contact.")
    contacts: ContactColumns
