"""A frame's request decoded and its pairs found, in steps that each run in the lane their
known cost chooses (:mod:`impactnet.service.limits.lanes`):

1. :func:`parse`: the body (JSON or npz) into its options and bodies; cost ~ the bytes;
2. :func:`decode`: the bodies as :class:`~impactnet.models.frame.Bodies` (inline parts built
   within their limits), joined to the registered world they name; cost ~ the bodies and the
   inline parts' corners;
3. :func:`broadphase`: the pairs of bodies that may touch or lie within the margin, held to
   ``max_batch_pairs``; cost ~ n log n.

:func:`advance` takes as many of them as their lane allows in one thread
(:meth:`~impactnet.service.limits.lanes.Work.chain`). The pairs are then solved like a
batch's (:mod:`impactnet.service.solve`); a refusal names the body by its id.
"""
from __future__ import annotations

from dataclasses import dataclass

from pydantic import ValidationError

from impactnet.models.frame import Bodies, FramePairs, TooManyBodyPairs, frame_pairs
from impactnet.service.batch_steps import PAIR_INPUT_BYTES, parse_cost
from impactnet.service.codecs import frame as fc
from impactnet.service.codecs.json_keys import validated_unique
from impactnet.service.codecs.npz import parse_npz
from impactnet.service.codecs.pair import inline_cost, part_limits
from impactnet.service.codecs.requests import FrameOptions, FrameRequest, WorldRequest
from impactnet.service.errors import InputError, LimitRefused, ServiceError, validation_items
from impactnet.service.limits.budget import Lease

__all__ = ["Parsed", "Prepared", "advance", "broadphase", "decode", "parse", "parse_cost"]


@dataclass
class Parsed:
    """A frame's (or world's) body decoded (step 1)."""

    options: FrameOptions  # what to answer (a world request: its convention only)
    bodies: list | None  # JSON: the FrameBody models
    columns: dict | None  # npz: the columns
    ids: list | None  # JSON: the ids as sent, to name bodies in errors
    rows: int  # bodies


def _query_options(query: dict, model=FrameOptions) -> FrameOptions:
    try:
        return model.model_validate({k: v for k, v in query.items() if v not in (None, [])})
    except ValidationError as exc:
        first = validation_items(exc.errors())[0]
        raise InputError(first["field"], first["reason"], type_=first["type"]) from exc


def parse(body: bytes, binary: bool, query: dict, settings, lease: Lease,
          world: bool = False) -> Parsed:
    """Step 1: a frame's (``world`` False) or a world's body."""
    model = WorldRequest if world else FrameRequest
    if binary:
        columns = parse_npz(body, settings.max_body_bytes, settings.max_frame_bodies, lease,
                            fc.FRAME_NPZ)
        rows = max((len(v) for v in columns.values() if getattr(v, "ndim", 0)), default=1)
        options = _query_options(query, FrameOptions)
        return Parsed(options, None, columns, None, rows)
    given = sorted(k for k, v in query.items() if v not in (None, []))
    if given:
        raise InputError(given[0], "a JSON frame gives its options in the body")
    try:
        request = validated_unique(model, body, "application/json")
    except ServiceError as exc:
        raise fc.name_bodies(exc, fc.ids_of(body)) from None
    if len(request.bodies) > settings.max_frame_bodies:
        raise fc.too_many_bodies(len(request.bodies), settings.max_frame_bodies)
    options = FrameOptions(euler_convention=request.euler_convention) if world else \
        FrameOptions.model_validate(request.model_dump(exclude={"bodies"}))
    return Parsed(options, request.bodies, None, [b.id for b in request.bodies],
                  len(request.bodies))


def decode_cost(parsed: Parsed, settings) -> float:
    """Step 2's cost: a body ~ a box-pair solve, and the inline parts' hulls."""
    inline = 0.0
    if parsed.bodies is not None:
        inline = inline_cost(((f"bodies[{k}]", b) for k, b in enumerate(parsed.bodies)),
                             part_limits(settings))
    return parsed.rows + inline


def decode(parsed: Parsed, scene, settings, lease: Lease, world: Bodies | None = None,
           notes: list | None = None) -> Bodies:
    """Step 2: the bodies, joined to ``world`` (static, first); 413 past
    ``max_frame_bodies``, a 422 naming the body by its id."""
    lease.reserve(parsed.rows * PAIR_INPUT_BYTES, "decoding the frame's bodies")
    convention = parsed.options.euler_convention
    try:
        if parsed.columns is not None:
            bodies = fc.npz_bodies(parsed.columns, scene, convention, settings.max_frame_bodies)
        else:
            bodies = fc.json_bodies(parsed.bodies, scene, part_limits(settings), convention,
                                    notes if notes is not None else [])
    except ServiceError as exc:
        ids = parsed.ids if parsed.ids is not None else (
            [str(i) for i in parsed.columns["id"]] if "id" in (parsed.columns or {}) else None)
        raise fc.name_bodies(exc, ids) from None
    if world is None:
        return bodies
    clash = sorted(set(world.ids) & set(bodies.ids))
    if clash:
        k = bodies.ids.index(clash[0])
        raise InputError(f"bodies[{k}].id", f"id {clash[0]!r} is a body of world "
                         f"{parsed.options.world!r}", type_="duplicate_id")
    if len(world) + len(bodies) > settings.max_frame_bodies:
        raise fc.too_many_bodies(len(world) + len(bodies), settings.max_frame_bodies)
    return world.joined(bodies)


def broadphase(bodies: Bodies, options: FrameOptions, scene, settings) -> FramePairs:
    """Step 3: the pairs that may touch or lie within the margin (413 past
    ``max_batch_pairs``)."""
    allowed = fc.allowed_pairs(bodies, scene) if options.pairs == "scene" else None
    try:
        return frame_pairs(bodies, options.margin, allowed, settings.max_batch_pairs)
    except TooManyBodyPairs as exc:
        raise LimitRefused("too_many_body_pairs", "bodies", f"more than {exc.cap} pairs of "
                           "bodies may touch or lie within the margin; send a smaller frame",
                           "max_batch_pairs") from None


@dataclass
class Prepared:
    """How far a frame's first three steps went (:func:`advance`)."""

    parsed: Parsed | None = None
    bodies: Bodies | None = None
    found: FramePairs | None = None
    cost: float = 0.0  # the next step's known cost (box-pair solves)

    @property
    def done(self) -> bool:
        return self.found is not None


def advance(progress: Prepared, request: tuple, stays) -> Prepared:
    """The steps not taken yet (parse, decode with the world the frame names, broadphase),
    for as long as the next step's known cost keeps it in this thread's lane
    (``stays(cost)``). ``request``: (body, binary, query, settings, lease, scene, worlds,
    notes)."""
    body, binary, query, settings, lease, scene, worlds, notes = request
    if progress.parsed is None:
        progress.parsed = parse(body, binary, query, settings, lease)
        progress.cost = decode_cost(progress.parsed, settings)
        if not stays(progress.cost):
            return progress
    options = progress.parsed.options
    if progress.bodies is None:
        held = worlds.get(options.world) if options.world else None
        progress.bodies = decode(progress.parsed, scene, settings, lease, held, notes)
        progress.cost = len(progress.bodies)
        if not stays(progress.cost):
            return progress
    progress.found = broadphase(progress.bodies, options, scene, settings)
    return progress
