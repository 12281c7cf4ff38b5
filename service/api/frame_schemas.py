"""The OpenAPI models of the frame's answers (POST /v2/frame, POST /v2/worlds): a frame's pair
is the one answer of a pair (:class:`impactnet.service.api.answer_schemas.PairAnswer`) with the
ids of its bodies."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from impactnet.service.api.answer_schemas import PairAnswer
from impactnet.service.codecs.requests import Mode


class FramePair(PairAnswer):
    """A pair of the frame's bodies that touch or lie within the margin."""

    a: str = Field(description="Body A's id (A comes first in the frame: the world's bodies "
                   "first, then the request's in order).")
    b: str = Field(description="Body B's id.")


class FrameResponse(BaseModel):
    """A frame's answer: the pairs of bodies that touch or lie within the margin."""

    model_config = ConfigDict(extra="forbid")

    n_bodies: int = Field(description="Bodies of the frame, its world's included.")
    world: str | None = Field(description="The registered world the frame named.")
    mode: Mode
    model_version: str
    pairs: list[FramePair] = Field(description="Each pair's answer as POST /v2/contact gives "
                                   "it, with `a` and `b`, the ids of its bodies.")
    warnings: list[str] = Field(None, description="Notes on inline parts (a mesh replaced by "
                                "its hull); absent when there are none.")


class WorldResponse(BaseModel):
    """A registered world."""

    world: str = Field(description="Its name, for a frame's `world`.")
    bodies: int = Field(description="Its bodies.")
    created: bool = Field(description="False when this replica held it already.")
