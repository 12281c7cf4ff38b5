"""The worlds of the frame benchmark: three variants of the same yard, yards of an exact body
count, and the scene the HTTP measurement's server serves.

Variants (the shapes a yard is made of; :data:`VARIANTS`):

* ``boxes``: scene ``quay_crane``'s 40 ft container and spreader (boxes). That scene has no cell
  guide, so the guides are scene ``quay_crane_detail``'s (two leg boxes, two convex entry
  plates): a few compound pairs;
* ``detail 1``: 40 ft containers at detail 1 (the body box and eight solid corner castings,
  ``crane_bodies.container("40ft", detail=1)``: box parts only, the model MuJoCo collides with
  its box-box collider alone), scene ``quay_crane_detail``'s spreader and cell guide;
* ``detail 2``: scene ``quay_crane_detail`` as served: containers whose top castings have their
  apertures (71 parts), the spreader's twistlocks with 32-sided heads, the cell guide.

A yard of exactly ``n`` bodies (:func:`counted_yard`): a spreader, four cell guides per guided
stack, and ``n - 1 - guides`` containers on a grid of stacks one to six high
(:func:`impactnet.models.frame.yard.yard`, which draws each stack's height): the grid is laid out
with a few more stacks than the mean height needs, and the tallest stacks (never the one under the
spreader) give up their top container until the count is exact; the spreader is landing
(:data:`LANDING_GAP_M`). The HTTP server serves :func:`scene_toml`, which names every variant's
bodies (:data:`OBJECTS`); its detail-2 bodies are scene ``quay_crane_detail``'s, part for part
(checked by :func:`scene_objects`).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from impactnet.models.dispatch.shapes import Shape, scene_shapes
from impactnet.models.frame import Bodies
from impactnet.models.frame.yard import Yard, YardLayout, yard

VARIANTS = ("boxes", "detail 1", "detail 2")
#: Per variant, the bench scene's object of each yard role (container, spreader, guide).
OBJECTS = {"boxes": ("container40_box", "spreader_box", "cell_guide"),
           "detail 1": ("container40_detail1", "spreader", "cell_guide"),
           "detail 2": ("container40", "spreader", "cell_guide")}
#: A stack's mean height (one to six, equally likely).
MEAN_HEIGHT = 3.5
#: Stacks laid out beyond the mean need (x), so that a yard seldom has too few containers.
STACK_SURPLUS = 1.2
#: Seeds tried (from the given one) for a yard with enough containers.
SEED_TRIES = 20
#: The spreader's lowest point below the top of the stack it lands on (m, negative: into it):
#: at detail 2 its twistlock heads reach into the top castings' apertures (touching a ring
#: where the container sits off centre), at detail 1 into the solid castings, a box spreader
#: presses on the roof; so that a frame of a static world and the spreader has its contacts.
LANDING_GAP_M = -0.002
#: The bench scene (TOML): every variant's bodies under distinct names.
SCENE = """[scene]
name = "frame_bench"
description = "impactnet bench frame: the yard variants' bodies (training/bench/frame)."
depth_fraction = [0.0, 0.001]

[accuracy]
normal_deg = 1.0
point_fraction = 0.02
part_point_fraction = 0.02

[bodies.container40_box]
size = [12.192, 2.438, 2.591]

[bodies.spreader_box]
size = [12.0, 2.35, 0.8]

[bodies.container40_detail1]
generator = "container"
kind = "40ft"
detail = 1

[bodies.container40]
generator = "container"
kind = "40ft"
detail = 2

[bodies.spreader]
generator = "spreader"
kind = "40ft"
sides = 32

[bodies.cell_guide]
generator = "cell_guide"
entry_angle_deg = 30.0

[[pairs]]
a = "container40"
b = "container40"
"""


def scene_toml() -> str:
    """The bench scene's text (module docstring)."""
    return SCENE


@functools.cache
def scene_objects() -> dict[str, Shape]:
    """The bench scene's shapes by name; raises if its detail-2 bodies are not scene
    ``quay_crane_detail``'s, part for part."""
    import tomllib

    from impactnet.models.scenes import load_scene, parse_scene

    shapes = scene_shapes(parse_scene(tomllib.loads(SCENE), source="frame_bench"))
    served = scene_shapes(load_scene("quay_crane_detail"))
    for name in OBJECTS["detail 2"]:
        if shapes[name].parts != served[name].parts:
            raise RuntimeError(f"the bench scene's {name} is not quay_crane_detail's")
    return shapes


@functools.cache
def variant_shapes(variant: str) -> dict[str, Shape]:
    """A variant's shapes under the yard's role names (container40, spreader, cell_guide),
    each keeping its bench scene name."""
    shapes = scene_objects()
    return dict(zip(("container40", "spreader", "cell_guide"),
                    (shapes[name] for name in OBJECTS[variant])))


def _stacks_of(world: Bodies, containers: int, layout: YardLayout) -> tuple[np.ndarray, ...]:
    """(stack index (c,), level (c,)) of the first ``containers`` bodies of a yard's world
    (containers come first, stack by stack, bottom up)."""
    z = world.position[:containers, 2]
    height = 2.0 * world.shapes[0].bounds[1][2]  # the container's envelope (the yard's pitch)
    levels = np.rint((z - z.min()) / (height - layout.stack_depth)).astype(np.int64)
    return np.cumsum(levels == 0) - 1, levels


def _trimmed(found: Yard, extra: int, layout: YardLayout) -> Yard:
    """``found`` without the top containers of its tallest stacks, ``extra`` of them (the
    last stack, under the spreader, is never trimmed)."""
    world = found.world
    containers = sum(i.startswith("c") for i in world.ids)
    stack, level = _stacks_of(world, containers, layout)
    heights = np.bincount(stack)
    for _ in range(extra):
        tallest = int(np.argmax(heights[:-1]))
        if heights[tallest] <= 1:
            raise ValueError("too few containers to trim")
        heights[tallest] -= 1
    keep = np.concatenate([np.flatnonzero(level < heights[stack]),
                           np.arange(containers, len(world))])
    kept = Bodies(tuple(world.ids[k] for k in keep), world.shapes, world.shape[keep],
                  world.position[keep], world.quaternion[keep])
    return Yard(kept, found.moving)


def counted_yard(shapes: dict[str, Shape], bodies: int, rows: int, seed: int,
                 guided_stacks: int = 2, spreader_gap: float = LANDING_GAP_M) -> Yard:
    """A seeded yard of exactly ``bodies`` bodies, ``rows`` stacks across (module docstring):
    one spreader, ``4 * guided_stacks`` cell guides, the rest containers; the spreader's
    lowest point ``spreader_gap`` (m) above the last stack's top."""
    containers = bodies - 1 - 4 * guided_stacks
    if containers < 1:
        raise ValueError(f"{bodies} bodies leave no room for containers")
    stacks = max(guided_stacks, 2, math.ceil(STACK_SURPLUS * containers / MEAN_HEIGHT))
    layout = YardLayout(rows=rows, cols=max(1, math.ceil(stacks / rows)),
                        guided_stacks=guided_stacks, spreader_gap=spreader_gap)
    for attempt in range(SEED_TRIES):
        found = yard(shapes, layout, seed + attempt)
        have = sum(i.startswith("c") for i in found.world.ids)
        if have >= containers:
            try:
                return _trimmed(found, have - containers, layout)
            except ValueError:
                continue
    raise RuntimeError(f"no yard of {bodies} bodies in {SEED_TRIES} seeds from {seed}")


def square_rows(bodies: int) -> int:
    """Rows of a yard of ``bodies`` about as wide as it is long: a stack takes 12.8 m along
    and 2.84 m across, so a square yard has ~4.5 rows per column."""
    stacks = STACK_SURPLUS * bodies / MEAN_HEIGHT
    return max(1, round(math.sqrt(stacks * 12.792 / 2.838)))


def columns(bodies: Bodies) -> dict[str, np.ndarray]:
    """npz columns of ``bodies`` (POST /v2/frame): ``id``, ``object`` (the bench scene's
    names), ``position``, ``quaternion``."""
    names = np.array([bodies.shapes[k].name for k in bodies.shape])
    return {"id": np.array(bodies.ids), "object": names, "position": bodies.position,
            "quaternion": bodies.quaternion}


def body_objects(bodies: Bodies) -> list[dict]:
    """JSON body objects of ``bodies`` (POST /v2/worlds)."""
    return [{"id": i, "object": bodies.shapes[k].name, "position": p.tolist(),
             "quaternion": q.tolist()}
            for i, k, p, q in zip(bodies.ids, bodies.shape, bodies.position, bodies.quaternion)]
