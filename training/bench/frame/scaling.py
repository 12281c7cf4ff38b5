"""How a frame's cost grows with its bodies (issue #34, item 4): ``answer_frame`` (exact, margin
0, every body free, so that the stacks' contacts are answered) on yards of
:attr:`ScalingPlan.frame_sizes` bodies, and the broadphase alone on more sizes, with a fit.

Yards (:func:`~impactnet.training.bench.frame.worlds.counted_yard`): stacks one to six high, a
spreader landing on the last stack, cell guides at the corners of two stacks (one for the
10-body yard), exactly the named number of bodies, laid out two ways:

* **square**: about as wide as long (:func:`~impactnet.training.bench.frame.worlds.square_rows`,
  ~4.5 rows of stacks per column): the general two-dimensional case;
* **block**: :attr:`ScalingPlan.block_rows` rows of stacks, as long as it takes (a yard block
  along a quay).

Per yard: the median wall time of the whole frame (a new ``Bodies`` from the arrays, then
``answer_frame``) after a warm-up call, as many calls as fit in the budget; the pairs the
broadphase finds and the pairs kept (touching); and the broadphase alone
(:func:`~impactnet.models.frame.broadphase.body_pairs` on prepared envelopes and rotations)
with the candidates its sweep walks: the pairs of bodies whose bounds overlap on the sweep axis,
of which the pairs found are those that overlap on all three. The fit (:func:`fit`) is
``t = c + a n log2 n + b x``, ``x`` the pairs found or the candidates walked, non-negative
coefficients, least relative squares over the yards of 100 bodies and more.
"""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

import numpy as np

from impactnet.training.bench.frame import worlds
from impactnet.training.bench.timing import call_times


@dataclass(frozen=True)
class ScalingPlan:
    """What the scaling section measures; :data:`QUICK_SCALING` is the smoke plan."""

    frame_sizes: tuple = (10, 100, 1_000, 10_000)
    broadphase_sizes: tuple = (10, 30, 100, 300, 1_000, 3_000, 10_000, 30_000)
    frame_variants: tuple = ("boxes", "detail 2")
    block_rows: int = 8
    frame_budget_s: float = 3.0  # timed calls of one whole frame, per yard and variant
    frame_calls: tuple = (3, 51)  # at least, at most
    broadphase_budget_s: float = 0.3
    broadphase_calls: tuple = (11, 501)
    fit_from: int = 100  # bodies: smaller yards are the call's fixed cost


QUICK_SCALING = ScalingPlan(frame_sizes=(10, 100, 1_000), broadphase_sizes=(10, 100, 1_000,
                            3_000), frame_variants=("boxes",), frame_budget_s=0.3,
                            frame_calls=(3, 11), broadphase_budget_s=0.05)


def _median(fn, budget_s: float, calls: tuple) -> tuple[float, int]:
    """(median s of ``fn()`` after one warm-up call, timed calls): as many as fit."""
    first = call_times([(fn, ())], 0)[0]
    count = int(min(calls[1], max(calls[0], math.ceil(budget_s / max(first, 1e-9)))))
    return statistics.median(call_times([(fn, ())] * count, 0)), count


def _guides(bodies: int) -> int:
    return 1 if bodies < 30 else 2


def yard_of(variant: str, bodies: int, layout: str, seed: int, plan: ScalingPlan):
    """The yard of ``bodies`` bodies of a variant, ``square`` or ``block``."""
    rows = worlds.square_rows(bodies)
    if layout == "block":
        rows = min(rows, plan.block_rows)
    return worlds.counted_yard(worlds.variant_shapes(variant), bodies, rows, seed,
                               _guides(bodies)), rows


def candidates(bodies) -> int:
    """The pairs whose bounds overlap on the sweep's axis: what the sweep walks."""
    from impactnet.models.frame import broadphase as bp

    centre, half = bodies.envelopes
    n = len(bodies)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    bp.world_bounds(centre, half, bodies.position, bodies.rotation, 0.0, lo, hi)
    axis = bp._sweep_axis(lo, hi)
    order = np.argsort(lo[:, axis], kind="stable")
    start, end = lo[order, axis], hi[order, axis]
    return int((np.searchsorted(start, end, side="right") - np.arange(n) - 1).sum())


def broadphase_point(bodies, plan: ScalingPlan) -> dict:
    """The broadphase alone on ``bodies`` (all free): median ms, pairs found, candidates."""
    from impactnet.models.frame.broadphase import body_pairs

    centre, half = bodies.envelopes
    args = (centre, half, bodies.position, bodies.rotation, 0.0, bodies.contype,
            bodies.conaffinity, bodies.static)
    seconds, calls = _median(lambda: body_pairs(*args), plan.broadphase_budget_s,
                             plan.broadphase_calls)
    return {"bodies": len(bodies), "pairs": int(len(body_pairs(*args))),
            "candidates": candidates(bodies), "ms": 1e3 * seconds, "calls": calls}


def frame_point(bodies, dispatcher, plan: ScalingPlan) -> dict:
    """The whole frame on ``bodies`` (all free): median ms, pairs kept, and the broadphase
    alone (its pairs found, ms)."""
    from impactnet.training.bench.frame.stages import frame_call

    call = frame_call(bodies, dispatcher)
    args = (bodies.position.copy(), bodies.quaternion.copy())
    kept = len(call(*args).index)
    seconds, calls = _median(lambda: call(*args), plan.frame_budget_s, plan.frame_calls)
    alone = broadphase_point(bodies, plan)
    return {"ms": 1e3 * seconds, "kept": int(kept), "calls": calls, "found": alone["pairs"],
            "broadphase_ms": alone["ms"]}


def stacks_of(bodies) -> int:
    """The stacks of a yard's frame: its containers standing on the ground."""
    containers = np.array([i.startswith("c") for i in bodies.ids])
    z = bodies.position[containers, 2]
    return int((z < z.min() + 0.5).sum())


def fit(points: list[dict], column: str, smallest: int) -> dict:
    """``t = c + a n log2 n + b x`` (x: ``column``) over the points of ``smallest`` bodies and
    more, non-negative, in least relative squares: coefficients (µs, ns, ns) and the largest
    relative residual."""
    from scipy.optimize import nnls

    used = [p for p in points if p["bodies"] >= smallest]
    n = np.array([p["bodies"] for p in used], float)
    t = np.array([p["ms"] for p in used]) * 1e-3
    x = np.array([p[column] for p in used], float)
    basis = np.stack([np.ones_like(n), n * np.log2(n), x], axis=1)
    coef, _ = nnls(basis / t[:, None], np.ones_like(t))
    model = basis @ coef
    return {"x": column, "points": len(used), "c_us": 1e6 * coef[0], "a_ns": 1e9 * coef[1],
            "b_ns": 1e9 * coef[2], "max_rel_residual": float(np.max(np.abs(model / t - 1)))}


def measure(plan: ScalingPlan, seed: int, log=lambda message: None) -> dict:
    """The section's figures as plain JSON types (module docstring)."""
    from impactnet.models.dispatch import Dispatcher

    out: dict = {"plan": plan.__dict__, "broadphase": {}, "frames": []}
    for layout in ("square", "block"):
        series = []
        for size in plan.broadphase_sizes:
            found, rows = yard_of("boxes", size, layout, seed, plan)
            series.append({"rows": rows, **broadphase_point(found.frame(False), plan)})
        out["broadphase"][layout] = {"points": series,
                                     "fit_pairs": fit(series, "pairs", plan.fit_from),
                                     "fit_candidates": fit(series, "candidates", plan.fit_from)}
        log(f"  broadphase, {layout} yards: {series[-1]['bodies']:,} bodies in "
            f"{series[-1]['ms']:.2f} ms")
    dispatcher = Dispatcher()
    for size in plan.frame_sizes:
        row: dict = {"bodies": size}
        for variant in plan.frame_variants:
            found, rows = yard_of(variant, size, "square", seed, plan)
            bodies = found.frame(False)
            row |= {"rows": rows, "stacks": stacks_of(bodies)}
            row[variant] = frame_point(bodies, dispatcher, plan)
            log(f"  frame, {variant}, {size:,} bodies: {row[variant]['ms']:.1f} ms")
        out["frames"].append(row)
    return out
