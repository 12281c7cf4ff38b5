"""One frame against MuJoCo called from Python, as ratios measured in one run (issue #34,
item 5, in process): a yard of :attr:`FramePlan.containers` containers, a spreader and
:attr:`FramePlan.guided_stacks` x 4 cell guides, per variant
(:data:`~impactnet.training.bench.frame.worlds.VARIANTS`), in two frames:

* **every body free**: the stacks' own contacts are answered too (MuJoCo: every body on a free
  joint); the goal is ``answer_frame`` within :data:`GOAL_IN_PROCESS` of MuJoCo;
* **world static**: the yard and the guides a registered world, the spreader the one body that
  moved (MuJoCo: the world's bodies welded to its world body, so that it skips their pairs).

Ours, per call: the poses' arrays into a new :class:`~impactnet.models.frame.Bodies`, then
``answer_frame`` (exact, margin 0) to its answers. MuJoCo, per call
(:mod:`~impactnet.training.bench.frame.mujoco_world`): qpos written, ``mj_kinematics``,
``mj_collision``, the contacts copied. The model and the dispatcher are built once, before any
clock starts; both sides get the same poses, timed in alternating slices
(:func:`~impactnet.training.bench.timing.alternated`), as many calls as fit in
:attr:`FramePlan.budget_s`. Before timing, both sides' touching pairs are compared (the same
set, or the report says where they differ). The stage profile of the free frame follows
(:mod:`~impactnet.training.bench.frame.stages`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from impactnet.training.bench.frame import worlds
from impactnet.training.bench.timing import alternated

#: Goal of ``answer_frame`` in process over MuJoCo's frame from Python (ratio, at most).
GOAL_IN_PROCESS = 2.0
#: Goal over HTTP (npz) over MuJoCo's frame from Python (ratio, at most).
GOAL_HTTP = 3.0


@dataclass(frozen=True)
class FramePlan:
    """How much the speed section measures; :data:`QUICK_FRAME` is the smoke plan."""

    containers: int = 200
    guided_stacks: int = 2  # four cell guides each
    rows: int = 4  # stacks across
    budget_s: float = 4.0  # per frame kind and variant: timed calls of both sides
    min_calls: int = 11
    max_calls: int = 401
    rounds: int = 3  # alternating slices
    profile_repeats: int = 7


QUICK_FRAME = FramePlan(budget_s=0.5, min_calls=3, max_calls=41, profile_repeats=3)


def bodies_count(plan: FramePlan) -> int:
    return plan.containers + 4 * plan.guided_stacks + 1


def calls_for(seconds: float, plan: FramePlan) -> int:
    """Timed calls per side that fit the budget, given one call of each side (s)."""
    return int(min(plan.max_calls, max(plan.min_calls, math.ceil(plan.budget_s / seconds))))


def time_pair(ours, theirs, args: tuple, plan: FramePlan) -> tuple[float, float, int]:
    """(median s of ``ours(*args)``, of ``theirs(*args)``, timed calls per side)."""
    started = time.perf_counter()
    ours(*args)
    theirs(*args)
    calls = calls_for(time.perf_counter() - started, plan)
    ours_s, theirs_s = alternated([(ours, args)] * (calls + 1), [(theirs, args)] * (calls + 1),
                                  1, plan.rounds)
    return ours_s, theirs_s, calls


def pairs_check(frame, model, geom: np.ndarray) -> dict:
    """Both sides' touching pairs: counts and whether they are the same set."""
    from impactnet.training.bench.frame.mujoco_world import body_pairs_of

    ours = {(int(i), int(j)) for i, j in frame.index}
    theirs = body_pairs_of(model, geom)
    return {"ours": len(ours), "mujoco": len(theirs), "same": ours == theirs,
            "only_ours": len(ours - theirs), "only_mujoco": len(theirs - ours)}


def measure_frame(bodies, dispatcher, plan: FramePlan) -> dict:
    """One frame kind of one variant: both sides' medians (ms), the ratio, the pairs."""
    from impactnet.training.bench.frame.mujoco_world import frame_call, world_model
    from impactnet.training.bench.frame.stages import frame_call as our_frame

    model, data, free = world_model(bodies)
    theirs = frame_call(model, data, free)
    ours = our_frame(bodies, dispatcher)
    args = (bodies.position.copy(), bodies.quaternion.copy())
    check = pairs_check(ours(*args), model, theirs.checked(*args)[3])
    ours_s, theirs_s, calls = time_pair(ours, theirs, args, plan)
    return {"bodies": len(bodies), "free_bodies": int(len(free)), "pairs": check,
            "contacts_mujoco": int(data.ncon), "calls": calls, "ours_ms": 1e3 * ours_s,
            "mujoco_ms": 1e3 * theirs_s, "ratio": ours_s / theirs_s}


def measure(plan: FramePlan, seed: int, log=lambda message: None) -> dict:
    """Every variant: the yard, its free and world-static frames, the free frame's profile
    (plain JSON types; ``yards`` keeps the yards for the HTTP section, not serialised)."""
    from impactnet.models.dispatch import Dispatcher
    from impactnet.training.bench.frame.stages import frame_stages
    from impactnet.training.bench.speed import stages as st

    dispatcher = Dispatcher()
    out: dict = {"plan": plan.__dict__, "variants": {}, "yards": {}}
    for variant in worlds.VARIANTS:
        found = worlds.counted_yard(worlds.variant_shapes(variant), bodies_count(plan),
                                    plan.rows, seed, plan.guided_stacks)
        out["yards"][variant] = found
        free, static = found.frame(False), found.frame(True)
        entry = {"free": measure_frame(free, dispatcher, plan),
                 "world": measure_frame(static, dispatcher, plan)}
        entry["profile"] = st.profile(f"answer_frame, {variant}, every body free", "frame", 1,
                                      lambda: frame_stages(free, dispatcher),
                                      plan.profile_repeats)
        out["variants"][variant] = entry
        log(f"  frame {variant}: {entry['free']['ours_ms']:.2f} ms / MuJoCo "
            f"{entry['free']['mujoco_ms']:.3f} ms = {entry['free']['ratio']:.1f}x")
    return out
