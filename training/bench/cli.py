"""CLI glue of `impactnet bench`: every predictor's speed and error, measured in one run.

    impactnet bench [--quick] [--out bench_results] [--seed 0] [--scene quay_crane] [--http]
                    [--grids 1,2,4,8,16,32,64] [--bundle PATH]
    impactnet bench exact [--quick] [--json PATH] [--seed 0] [--baseline DIR]
    impactnet bench compound [--quick] [--out DIR] [--plot PNG] [--seed 1]
    impactnet bench hostile [--quick] [--out DIR] [--scene quay_crane_detail]
    impactnet bench speed [--quick] [--out DIR] [--seed 0] [--scene quay_crane]
    impactnet bench frame [--quick] [--out DIR] [--plot PNG] [--seed 0] [--no-http]
                          [--threads N]

The first form measures the exact solver, python-fcl's Box-Box, the paper's polygon method at
each grid size and the learned predictors (``models.load_predictor``; "not available: <reason>"
while there is no bundle) on the scene's first-contact poses and the paper's Figure 2 case,
with a "vs MuJoCo" column (every method against MuJoCo's box-box and a grid centre of pressure,
:mod:`impactnet.training.bench.accuracy.vs_mujoco`; noted as not available without the dev extra's
mujoco), and writes ``results.md``, ``results.json``, ``pareto.png``, ``polygon_grid.png`` and
``figure2_tilt.png`` into ``--out`` (the Markdown is also printed). See
:mod:`impactnet.training.bench`. The second form is the exact solver's own benchmark
(:mod:`impactnet.training.bench.exact.vs_fcl`). The third is the compound bodies' benchmark: the
exact compound oracle's cost against detail next to FCL and MuJoCo, with issue #20's goals
(:mod:`impactnet.training.bench.compound.detail`). The first form ends with the speed section
(issue #32): box pairs against MuJoCo called from Python and the per-stage profile
(:mod:`impactnet.training.bench.speed`); ``speed`` runs that section alone and writes
``speed.md`` and ``speed.json`` into ``--out``. ``frame`` is issue #34's benchmark of a frame
in one call (:mod:`impactnet.training.bench.frame`): its scaling from 10 to 10,000 bodies and
its speed against MuJoCo in process and over HTTP; it writes ``frame.md``, ``frame.json`` and
the scaling figure.

``impactnet/cli.py`` calls :func:`add_arguments` on its ``bench`` subparser and :func:`run`
with the parsed arguments. Without that wiring: ``python -m impactnet.training.bench.cli [...]``.
Nothing heavy is imported at module level (numpy comes after the thread count is pinned).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from impactnet.training.bench.timing import pin_single_thread  # stdlib only: numpy stays out

DEFAULT_OUT = "bench_results"


def _grids(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected integers like 1,2,4, got {text!r}") from exc
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"grid sizes must be >= 1, got {text!r}")
    return values


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `impactnet bench`, and its `exact` sub-command."""
    parser.add_argument("--quick", action="store_true",
                        help="the smoke-test plan: small sets, few repeats (under a minute)")
    parser.add_argument("--out", default=DEFAULT_OUT,
                        help=f"folder of the report, JSON and figures (default {DEFAULT_OUT})")
    parser.add_argument("--seed", type=int, default=0, help="pose seed (default 0)")
    parser.add_argument("--scene", default=None,
                        help="scene name or TOML path (default quay_crane)")
    parser.add_argument("--http", action="store_true",
                        help="also measure /v2/contact and /v2/contact/batch through a server "
                             "started on 127.0.0.1 (a free port) and stopped at the end")
    parser.add_argument("--grids", type=_grids, default=None,
                        help="polygon grid sizes n, comma-separated (default 1,2,4,8,16,32,64)")
    parser.add_argument("--bundle", default=None,
                        help="learned bundle folder (default: the shipped bundle of the scene)")
    sub = parser.add_subparsers(dest="bench_command", metavar="BENCH")
    exact = sub.add_parser(
        "exact", help="pairs/s of impactnet.models.box.exact.box_box next to python-fcl, one "
                      "thread",
        description="Pairs/s and microseconds per pair of impactnet.models.box.exact.box_box at N "
                    "= 1, 1e3, "
                    "1e5 on first-contact cube poses, next to python-fcl's Box-Box collide "
                    "called in a Python loop over the same poses, on one thread.")
    exact.add_argument("--quick", action="store_true", help="fewer repeats (a smoke run)")
    exact.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    exact.add_argument("--seed", type=int, default=0, help="pose generator seed (default 0)")
    exact.add_argument("--baseline", metavar="DIR",
                       help="an earlier checkout (e.g. from `git worktree add DIR REV`): its "
                            "N = 1 time is measured next to this one's, alternately")
    compound = sub.add_parser(
        "compound", help="the compound oracle's cost against detail next to FCL mesh-mesh, "
                         "FCL Convex and MuJoCo, with their errors",
        description="Castings, apertures and twistlock heads of 8-256 sides: the compound "
                    "oracle (batch and N = 1) next to python-fcl mesh-mesh, python-fcl Convex "
                    "and MuJoCo on the same first-contact poses, with their errors against it, "
                    "and issue #20's goals (a few minutes; --quick: under a minute).")
    compound.add_argument("--quick", action="store_true", help="a tenth of the poses")
    compound.add_argument("--out", metavar="DIR", help="write compound.md there "
                          "(e.g. docs/benchmarks)")
    compound.add_argument("--plot", metavar="PNG", help="write the plot of cost against detail "
                          "there (default: compound_cost_vs_detail.png in --out)")
    compound.add_argument("--seed", type=int, default=1, help="pose seed (default 1)")
    moe = sub.add_parser(
        "moe", help="compound pairs: the learned path (auto) against the compound oracle",
        description="Per compound pair of the scene: auto (classifiers, experts, the oracle "
                    "for unsure rows) scored on held-out rows and timed against the compound "
                    "oracle at N = 1 and N = 1e5, the decision rule applied, and the cost "
                    "against the twistlock heads' detail (a few minutes; --quick: 2,000).")
    moe.add_argument("--quick", action="store_true", help="few poses and calls (smoke run)")
    moe.add_argument("--scene", default="quay_crane_detail", help="scene name or TOML path")
    moe.add_argument("--bundle", default=None, help="bundle folder (default: the shipped)")
    moe.add_argument("--data", default="data", help="training data folder (held-out rows)")
    moe.add_argument("--out", metavar="DIR", help="write moe.md, moe.json and the plot there")
    moe.add_argument("--plot", metavar="PNG", help="the plot's path (default: in --out)")
    moe.add_argument("--http", action="store_true", help="also issue #21's HTTP goals: a "
                     "server on 127.0.0.1 with the scene, /v2/contact and a 100k npz batch")
    hostile = sub.add_parser(
        "hostile", help="what the hostile probe's requests cost a replica (issue #31)",
        description="Each hostile reproducer (inline geometry, compound batches that amplify, "
                    "a disconnect, a request past its deadline) against a fresh server on "
                    "127.0.0.1: statuses, wall time, peak and idle memory, /healthz p99, CPU; "
                    "and a 10-pair batch's latency while two large batches run (~5 minutes).")
    hostile.add_argument("--quick", action="store_true", help="a tenth of the rows")
    hostile.add_argument("--out", metavar="DIR", help="write hostile.md there")
    hostile.add_argument("--scene", default="quay_crane_detail", help="scene name or path")
    speed = sub.add_parser(
        "speed", help="box_box and the stage profile against MuJoCo called from Python "
                      "(issue #32), alone",
        description="The speed section of `impactnet bench` alone: box_box at N = 1 against "
                    "MuJoCo's one pair from Python, a batch against MuJoCo's C rate (1,000 "
                    "explicit pairs per mj_collision) on all cores and one thread, on the "
                    "scene's first contacts and the stacking families, and the per-stage "
                    "profile of the box solver and the compound oracle.")
    speed.add_argument("--quick", action="store_true", help="the smoke plan (well under a "
                       "minute)")
    speed.add_argument("--out", default=DEFAULT_OUT, help="folder of speed.md and speed.json "
                       f"(default {DEFAULT_OUT})")
    speed.add_argument("--seed", type=int, default=0, help="pose seed (default 0)")
    speed.add_argument("--scene", default="quay_crane", help="scene name or TOML path")
    frame = sub.add_parser(
        "frame", help="a frame in one call (issue #34): scaling, and speed against MuJoCo in "
                      "process and over HTTP",
        description="answer_frame on yards of 10 to 10,000 bodies (and its broadphase alone, "
                    "with a fit), then one 200-container yard against MuJoCo's mj_collision "
                    "called from Python, in process and over POST /v2/frame (npz) through a "
                    "server started on 127.0.0.1, with the stage profiles (a few minutes; "
                    "--quick: well under a minute).")
    frame.add_argument("--quick", action="store_true", help="the smoke plan")
    frame.add_argument("--out", default=DEFAULT_OUT, help="folder of frame.md and frame.json "
                       f"(default {DEFAULT_OUT})")
    frame.add_argument("--plot", metavar="PNG", help="the scaling figure's path (default: "
                       "frame_scaling.png in --out)")
    frame.add_argument("--seed", type=int, default=0, help="yard seed (default 0)")
    frame.add_argument("--no-http", dest="http", action="store_false",
                       help="leave out the HTTP measurement")
    frame.add_argument("--threads", type=int, default=None, help="the compiled kernels' "
                       "threads (default 1, as MuJoCo's collision)")
    decide = sub.add_parser(
        "decide", help="per pair of a box scene: exact-only or learned, by issue #21's rule",
        description="Per pair of a box scene: the exact solver and the bundle's auto mode "
                    "(fallback included) timed at N = 1 and N = 1e5 on the pair's first-contact "
                    "poses, auto scored at the scene's tolerance, and the decision: learned "
                    "only where auto is >= 2x faster at both and within tolerance.")
    decide.add_argument("--quick", action="store_true", help="2,000 poses per pair")
    decide.add_argument("--scene", default="quay_crane", help="scene name or TOML path")
    decide.add_argument("--bundle", default=None, help="bundle folder (default: the shipped)")
    decide.add_argument("--out", metavar="DIR", help="write decide.md and decide.json there")
    decide.add_argument("--seed", type=int, default=0, help="pose seed (default 0)")


def _pin_single_thread() -> None:
    if not pin_single_thread():  # numpy came first: too late for BLAS to see it
        print("impactnet bench: warning: numpy was imported before the thread count was "
              "pinned; BLAS may use several threads.", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark (or ``bench exact``); 0 on success."""
    _pin_single_thread()
    if getattr(args, "bench_command", None) == "compound":
        from impactnet.training.bench.compound.detail import run as run_compound

        command = "impactnet bench compound" + (" --quick" if args.quick else "") + (
            f" --out {args.out}" if args.out else "") + (
            f" --plot {args.plot}" if args.plot else "") + (
            f" --seed {args.seed}" if args.seed != 1 else "")
        return run_compound(quick=args.quick, out=args.out, seed=args.seed, command=command,
                            plot_path=args.plot)
    if getattr(args, "bench_command", None) == "moe":
        from dataclasses import replace

        from impactnet.training.bench.learned.moe import QUICK as MOE_QUICK
        from impactnet.training.bench.learned.moe import MoeConfig
        from impactnet.training.bench.learned.moe import run as run_moe

        config = replace(MOE_QUICK if args.quick else MoeConfig(), scene=args.scene,
                         bundle=args.bundle, data=args.data, http=args.http)
        run_moe(config, args.out, args.plot)
        return 0
    if getattr(args, "bench_command", None) == "hostile":
        from impactnet.training.bench.http.hostile import run as run_hostile

        run_hostile(quick=args.quick, out=args.out, scene=args.scene)
        return 0
    if getattr(args, "bench_command", None) == "decide":
        from dataclasses import replace

        from impactnet.training.bench.learned.decide import QUICK as DECIDE_QUICK
        from impactnet.training.bench.learned.decide import DecideConfig
        from impactnet.training.bench.learned.decide import run as run_decide

        config = replace(DECIDE_QUICK if args.quick else DecideConfig(), scene=args.scene,
                         bundle=args.bundle, seed=args.seed)
        run_decide(config, args.out)
        return 0
    if getattr(args, "bench_command", None) == "speed":
        from impactnet.training.bench.speed.section import run as run_speed

        return run_speed(quick=args.quick, out=Path(args.out), seed=args.seed,
                         scene=args.scene)
    if getattr(args, "bench_command", None) == "frame":
        from impactnet.training.bench.frame.section import DEFAULT_THREADS
        from impactnet.training.bench.frame.section import run as run_frame

        command = "impactnet bench frame" + (" --quick" if args.quick else "") + (
            f" --out {args.out}" if args.out != DEFAULT_OUT else "") + (
            f" --plot {args.plot}" if args.plot else "") + (
            f" --seed {args.seed}" if args.seed else "") + (
            "" if args.http else " --no-http") + (
            f" --threads {args.threads}" if args.threads is not None else "")
        return run_frame(quick=args.quick, out=Path(args.out),
                         plot=Path(args.plot) if args.plot else None, seed=args.seed,
                         http=args.http, threads=args.threads or DEFAULT_THREADS,
                         command=command)
    if getattr(args, "bench_command", None) == "exact":
        from impactnet.training.bench.exact.vs_fcl import run as run_exact

        return run_exact(quick=args.quick, json_path=args.json, seed=args.seed,
                         baseline=args.baseline)
    from impactnet.training.bench import report
    from impactnet.training.bench.measure import QUICK, BenchConfig, with_overrides
    from impactnet.training.bench.runner import run_bench

    config = with_overrides(QUICK if args.quick else BenchConfig(), seed=args.seed,
                            scene=args.scene, http=args.http or None,
                            grid_sizes=args.grids, bundle=args.bundle)
    results = run_bench(config, mode="quick" if args.quick else "full")
    paths = report.write(results, Path(args.out))
    print(report.markdown(results))
    print(f"impactnet bench: wrote {', '.join(str(p) for p in paths)} in "
          f"{results['seconds']:.0f} s", file=sys.stderr)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="impactnet bench", description=__doc__.split("\n")[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
