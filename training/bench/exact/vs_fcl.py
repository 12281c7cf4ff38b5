"""Speed of the exact solver, next to python-fcl, on one thread: `impactnet bench exact`.

    impactnet bench exact [--quick] [--json PATH] [--seed S] [--baseline DIR]
    python -m impactnet.training.bench.exact.vs_fcl [--quick] [--json PATH] [--seed S]
        [--baseline DIR]

What is measured
----------------
Poses: first contacts of the paper's cube pair (edge 2 m) from
``impactnet.models.geometry.poses.first_contact_poses(n, size_a, size_b, rng)``, seeded.

* ``impactnet.models.box.exact.box_box`` (full manifold, float64):
  - N = 1: one pair per call (1-D inputs, the way a simulator calls it), each call timed on its
    own over many different poses; the median is reported, the first calls are warm-up.
  - N = 1e3, 1e5 (and 1e4 in the full mode): one batched call over N poses, repeated; the
    median over repeats is reported, the first (warm-up) call is not counted.
* python-fcl ``collide`` on two ``fcl.Box`` objects (contacts on, ``GST_LIBCCD``; for Box-Box
  FCL runs its analytic box-box routine), in a Python loop over the same poses: per pair, set
  both transforms, collide into a fresh ``CollisionResult`` and read normal, depth and point of
  the first contact into arrays. N = 1, 1e3 and 1e5 (and 1e4 in the full mode), each only if it
  fits the time budget. Nothing is extrapolated: a size left out says "not measured".
* ``--baseline DIR``: the N = 1 median of an earlier checkout (for example the commit before a
  change, from ``git worktree add DIR REV``) next to this one's, timed alternately in child
  processes on the same poses (:mod:`impactnet.training.bench.exact.baseline`).

Goals (the speed budget of the tie rule and the centre of pressure, issues 11 and 18): at
N = 1e5 the exact solver is at least 7x faster per pair than the FCL loop on the same poses, in
the same run; at N = 1 it is within 1.5x of the baseline checkout.

Speed-ups are ratios of medians measured in this same run. BLAS / OpenMP are pinned to one
thread (set before numpy is imported; see `pin_single_thread` in training/bench/timing.py) and the
garbage collector is paused while timing.
"""
from __future__ import annotations

import os

# One thread: these must be set before numpy is first imported (BLAS reads them when it loads).
# `impactnet bench exact` has set them already; this covers `python -m
# impactnet.training.bench.exact.vs_fcl`.
from impactnet.training.bench.timing import (  # noqa: E402  (stdlib only: numpy not yet)
    machine_info,
    median_per_call,
    median_repeated,
    pin_single_thread,
)

pin_single_thread()

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from dataclasses import asdict, dataclass, field  # noqa: E402

import numpy as np  # noqa: E402

CUBE = (2.0, 2.0, 2.0)  # the paper's cube pair, edge 2 m
GOAL_FCL_RATIO_1E5 = 7.0  # issue 18: exact / FCL-loop pairs/s at N = 1e5, same run, at least
GOAL_BASELINE_RATIO_N1 = 1.5  # issue 18: N = 1 time / the baseline checkout's, at most
BASELINE_HELP = ("an earlier checkout (e.g. from `git worktree add DIR REV`): its N = 1 time is "
                 "measured next to this one's, alternately, on the same poses")
FCL_BUDGET_S = 90.0  # skip an FCL size > 1e3 whose loops (repeats + warm-up) would take longer


@dataclass
class Plan:
    """How much to time; `quick` trades precision for a run of a few seconds."""

    single_calls: int  # N = 1: timed calls (distinct poses), after warm-up
    single_warmup: int  # N = 1: calls before timing starts
    batch_sizes: tuple[int, ...]  # batched N for the exact solver
    batch_repeats: dict[int, int]  # N -> timed repeats (one warm-up call more)
    fcl_sizes: tuple[int, ...]  # N for the FCL loop (1 is timed per call like the exact one)
    fcl_repeats: dict[int, int]  # N -> timed repeats of the whole loop


QUICK = Plan(300, 30, (1_000, 100_000), {1_000: 20, 100_000: 3}, (1, 1_000, 100_000),
             {1_000: 3, 100_000: 1})
FULL = Plan(
    5_000, 200, (1_000, 10_000, 100_000), {1_000: 200, 10_000: 50, 100_000: 15},
    (1, 1_000, 10_000, 100_000), {1_000: 20, 10_000: 5, 100_000: 3},
)


@dataclass
class Row:
    """One line of the table: a solver at one N."""

    solver: str  # "exact" or "fcl"
    n: int  # pairs per call (exact) or per loop (fcl)
    seconds: float  # median wall time of one call / one loop
    repeats: int  # timed calls or loops behind the median
    pairs_per_s: float = field(init=False)
    us_per_pair: float = field(init=False)

    def __post_init__(self) -> None:
        self.pairs_per_s = self.n / self.seconds
        self.us_per_pair = 1e6 * self.seconds / self.n


# ----------------------------------------------------------------------------- machine, timing

# Shared with `impactnet bench` (training/bench/timing.py); the old private names stay.
_median_per_call = median_per_call
_median_repeated = median_repeated


def _slice(poses: dict, n: int) -> tuple[np.ndarray, ...]:
    keys = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
    return tuple(np.ascontiguousarray(poses[k][:n], dtype=np.float64) for k in keys)


# ----------------------------------------------------------------------------- FCL


def make_fcl_loop():
    """A function running python-fcl Box-Box over pose arrays, or None without python-fcl."""
    try:
        import fcl
    except ImportError:
        return None, None
    request = fcl.CollisionRequest(num_max_contacts=8, enable_contact=True,
                                   gjk_solver_type=fcl.GJKSolverType.GST_LIBCCD)

    def loop(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
        n = len(position_a)
        normal, depth, point = np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3))
        boxes: dict[tuple, tuple] = {}
        for i in range(n):
            key = (*size_a[i], *size_b[i])
            if key not in boxes:  # fcl.Box takes full side lengths; built once per size pair
                boxes[key] = (fcl.CollisionObject(fcl.Box(*size_a[i])),
                              fcl.CollisionObject(fcl.Box(*size_b[i])))
            obj_a, obj_b = boxes[key]
            obj_a.setTransform(fcl.Transform(quaternion_a[i], position_a[i]))  # q = (w, x, y, z)
            obj_b.setTransform(fcl.Transform(quaternion_b[i], position_b[i]))
            result = fcl.CollisionResult()
            if fcl.collide(obj_a, obj_b, request, result):
                contact = result.contacts[0]
                normal[i], depth[i], point[i] = contact.normal, contact.penetration_depth, \
                    contact.pos
        return normal, depth, point

    settings = {"num_max_contacts": 8, "enable_contact": True, "gjk_solver_type": "GST_LIBCCD"}
    return loop, settings


# ----------------------------------------------------------------------------- report


def _fmt_rate(x: float) -> str:
    return f"{x:,.0f}"


def _fmt_us(x: float) -> str:
    return f"{x:.3g}" if x < 10 else f"{x:,.1f}"


def markdown_table(rows: list[Row]) -> str:
    """Exact and FCL side by side per N; speed-up = exact pairs/s / FCL pairs/s, same run."""
    exact = {r.n: r for r in rows if r.solver == "exact"}
    fcl = {r.n: r for r in rows if r.solver == "fcl"}
    lines = [
        "| N | exact pairs/s | exact µs/pair | FCL loop pairs/s | FCL loop µs/pair "
        "| exact / FCL | repeats (exact, FCL) |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for n in sorted(set(exact) | set(fcl)):
        e, f = exact.get(n), fcl.get(n)
        cells = [f"{n:,}"]
        cells += [_fmt_rate(e.pairs_per_s), _fmt_us(e.us_per_pair)] if e else ["-", "-"]
        cells += ([_fmt_rate(f.pairs_per_s), _fmt_us(f.us_per_pair)] if f
                  else ["not measured", "not measured"])
        cells.append(f"{e.pairs_per_s / f.pairs_per_s:.1f}x" if e and f else "-")
        cells.append(f"{e.repeats if e else '-'}, {f.repeats if f else '-'}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def goals(rows: list[Row], baseline: dict | None = None) -> list[str]:
    """The speed budget, met or not: the FCL ratio at N = 1e5, N = 1 against the baseline."""
    by_key = {(r.solver, r.n): r for r in rows}
    exact, fcl = by_key.get(("exact", 100_000)), by_key.get(("fcl", 100_000))
    out = []
    if exact and fcl:
        ratio = exact.pairs_per_s / fcl.pairs_per_s
        out.append(f"N = 1e5: exact / FCL loop = {ratio:.1f}x (goal >= {GOAL_FCL_RATIO_1E5:g}x): "
                   f"{'met' if ratio >= GOAL_FCL_RATIO_1E5 else 'NOT met'}")
    else:
        out.append("N = 1e5: FCL loop not measured, no ratio")
    if baseline:
        ratio = baseline["ratio"]
        out.append(f"N = 1: {baseline['current_us']:.1f} µs vs {baseline['baseline_us']:.1f} µs "
                   f"for {baseline['baseline']} = {ratio:.2f}x (goal <= "
                   f"{GOAL_BASELINE_RATIO_N1:g}x): "
                   f"{'met' if ratio <= GOAL_BASELINE_RATIO_N1 else 'NOT met'}")
    else:
        out.append("N = 1: no --baseline checkout given, the 1.5x budget is not checked")
    return out


# ----------------------------------------------------------------------------- main


def measure(plan: Plan, seed: int = 0, log=print) -> tuple[list[Row], dict]:
    """Time the exact solver and the FCL loop according to ``plan``; returns rows and notes."""
    from impactnet.models.box.exact import box_box
    from impactnet.models.geometry.poses import first_contact_poses

    n_max = max(plan.batch_sizes + plan.fcl_sizes + (plan.single_calls + plan.single_warmup,))
    t0 = time.perf_counter()
    poses = first_contact_poses(n_max, np.asarray(CUBE), np.asarray(CUBE),
                                np.random.default_rng(seed))
    notes = {"poses": n_max, "pose_generation_s": round(time.perf_counter() - t0, 3)}
    log(f"generated {n_max:,} first-contact cube poses in {notes['pose_generation_s']} s")

    rows: list[Row] = []
    columns = _slice(poses, plan.single_calls + plan.single_warmup)
    singles = list(zip(*columns, strict=True))
    seconds, count = _median_per_call(box_box, singles, plan.single_warmup)
    rows.append(Row("exact", 1, seconds, count))
    for n in plan.batch_sizes:
        args = _slice(poses, n)
        rows.append(Row("exact", n, _median_repeated(lambda a=args: box_box(*a),
                                                     plan.batch_repeats[n]),
                        plan.batch_repeats[n]))
        log(f"exact N = {n:,}: {rows[-1].pairs_per_s:,.0f} pairs/s")

    loop, fcl_settings = make_fcl_loop()
    notes["fcl"] = fcl_settings or "python-fcl not installed: FCL columns not measured"
    if loop is not None:
        one_pair = [tuple(c[None, :] for c in pair) for pair in singles]
        seconds, count = _median_per_call(loop, one_pair, plan.single_warmup)
        rows.append(Row("fcl", 1, seconds, count))
        for n in plan.fcl_sizes:
            if n == 1:
                continue
            per_pair = max(r.seconds / r.n for r in rows if r.solver == "fcl")
            if n > 1_000 and per_pair * n * (plan.fcl_repeats[n] + 1) > FCL_BUDGET_S:
                notes[f"fcl_{n}"] = "skipped: over the time budget"
                continue
            args = _slice(poses, n)
            rows.append(Row("fcl", n, _median_repeated(lambda a=args: loop(*a),
                                                       plan.fcl_repeats[n]),
                            plan.fcl_repeats[n]))
            log(f"fcl loop N = {n:,}: {rows[-1].pairs_per_s:,.0f} pairs/s")
    return rows, notes


def compare_with_baseline(plan: Plan, seed: int, baseline: str, log) -> dict:
    """N = 1 of ``baseline`` (a checkout) and of this code, alternately, on this run's poses."""
    from pathlib import Path

    import impactnet.models.box.exact
    from impactnet.models.geometry.poses import first_contact_poses
    from impactnet.training.bench.exact.baseline import compare_single_pair

    calls = plan.single_calls + plan.single_warmup
    poses = first_contact_poses(calls, np.asarray(CUBE), np.asarray(CUBE),
                                np.random.default_rng(seed))
    current = Path(impactnet.models.box.exact.__file__).resolve().parents[2]
    return compare_single_pair(poses, calls, Path(baseline), current, log=log)


def run(quick: bool = False, json_path: str | None = None, seed: int = 0,
        baseline: str | None = None) -> int:
    """Measure, print the Markdown report, optionally write JSON. Returns an exit status."""
    try:
        import impactnet.models.box.exact  # noqa: F401
        import impactnet.models.geometry.poses  # noqa: F401
    except ImportError as exc:
        print(f"impactnet bench exact: missing a dependency of the benchmark ({exc}); it needs "
              "the train extra: pip install -e '.[train]' (make bench installs it).",
              file=sys.stderr)
        return 1
    plan = QUICK if quick else FULL
    machine = machine_info()

    def log(message: str) -> None:
        print(message, file=sys.stderr, flush=True)

    rows, notes = measure(plan, seed=seed, log=log)
    versus = compare_with_baseline(plan, seed, baseline, log) if baseline else None
    table = markdown_table(rows)
    mode = "quick" if quick else "full"
    print(f"## impactnet.models.box.exact.box_box vs python-fcl Box-Box ({mode} run, "
          f"one thread)\n")
    print(f"Machine: {machine['cpu']}, {machine['cores']} cores; Python {machine['python']}, "
          f"numpy {machine['numpy']}, python-fcl {machine['python-fcl']}.")
    print(f"Poses: {notes['poses']:,} first contacts of two cubes of edge 2 m, seed {seed}. "
          "N = 1: median over single calls; N > 1: median over repeated batched calls "
          "(warm-up excluded). FCL: a Python loop over the same poses, not extrapolated.\n")
    print(table)
    print()
    for line in goals(rows, versus):
        print(f"- {line}")
    if json_path:
        report = {
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "mode": "quick" if quick else "full",
            "seed": seed,
            "machine": machine,
            "plan": asdict(plan),
            "notes": notes,
            "rows": [asdict(r) for r in rows],
            "baseline_n1": versus,
            "goals": goals(rows, versus),
        }
        os.makedirs(os.path.dirname(os.path.abspath(json_path)), exist_ok=True)
        with open(json_path, "w", encoding="utf-8") as f:
            json.dump(report, f, indent=2)
        log(f"wrote {json_path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.training.bench.exact.vs_fcl",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (a smoke run)")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    parser.add_argument("--seed", type=int, default=0, help="pose generator seed")
    parser.add_argument("--baseline", metavar="DIR", help=BASELINE_HELP)
    args = parser.parse_args(argv)
    return run(quick=args.quick, json_path=args.json, seed=args.seed, baseline=args.baseline)


if __name__ == "__main__":
    raise SystemExit(main())
