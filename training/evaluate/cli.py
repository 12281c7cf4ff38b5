"""`impactnet evaluate`: argument parsing and the command body, for impactnet/cli.py to wire in.

    impactnet evaluate --scene quay_crane --bundle models/bundles/quay_crane
                       --out docs/evaluation [--rows 100000] [--seed 0] [--quick] [--check]

Measures every predictor of the bundle on fresh test rows of each pair of the scene and on the
paper's protocol (:mod:`impactnet.training.evaluate.run`), writes ``report.md``, ``evaluation.json``
and the PNG figures into ``--out``, and prints the goals of issue 4 with met / missed.

Exit status: 0 done (goals met or not, unless ``--check``); 1 with ``--check`` when a goal is
missed; 2 bad arguments, unknown scene, or a missing, altered or foreign bundle. Nothing heavy
is imported at module level; numpy comes after the thread count is pinned to one.
"""
from __future__ import annotations

import argparse
import sys

EXIT_OK, EXIT_GOAL_MISSED, EXIT_USAGE = 0, 1, 2
DEFAULT_OUT = "docs/evaluation"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `evaluate` options to ``parser``."""
    parser.add_argument("--scene", default="quay_crane",
                        help="scene name (scenes/ or $IMPACTNET_SCENES_DIR) or .toml path "
                             "(default: quay_crane)")
    parser.add_argument("--bundle", default=None,
                        help="bundle folder (default: models/bundles/<scene>)")
    parser.add_argument("--out", default=DEFAULT_OUT,
                        help=f"folder of report.md, evaluation.json and the figures "
                             f"(default: {DEFAULT_OUT})")
    parser.add_argument("--rows", type=int, default=None,
                        help="test rows per body pair (default: 100000; --quick: 2000)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the test rows, >= 0; drawn from a stream that training "
                             "never uses, so any seed gives held-out data (default: 0)")
    parser.add_argument("--quick", action="store_true",
                        help="2,000 rows per pair and small paper sets: a smoke run in seconds")
    parser.add_argument("--check", action="store_true",
                        help="exit with status 1 when a goal of issue 4 is missed")


def _config(args: argparse.Namespace):
    """The EvaluateConfig of ``args``; ValueError on bad values."""
    from impactnet.training.evaluate.run import EvaluateConfig, quick_config

    if args.rows is not None and args.rows < 1:
        raise ValueError(f"--rows must be >= 1, got {args.rows}")
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    if args.quick:
        return quick_config(args.seed, args.rows)
    return EvaluateConfig(seed=args.seed, **({"rows": args.rows} if args.rows else {}))


def run(args: argparse.Namespace) -> int:
    """Evaluate the bundle named by ``args``; returns the exit status."""
    from impactnet.training.bench.cli import _pin_single_thread

    _pin_single_thread()
    from pathlib import Path

    from impactnet.models.bundle.format import BundleError
    from impactnet.models.scenes import SceneError, load_scene
    from impactnet.training.data.compound_dataset import is_compound_scene
    from impactnet.training.evaluate.run import evaluate, write

    try:
        config = _config(args)
        scene = load_scene(args.scene)
        if is_compound_scene(scene):
            return _run_compound(scene, args)
        scene.require_box_pairs("impactnet evaluate")  # a scene mixing both is refused
        bundle = Path(args.bundle or f"models/bundles/{scene.name}")
        if not bundle.is_dir():
            raise ValueError(f"no bundle at {bundle} (build one with `impactnet train --scene "
                             f"{scene.name} --out {bundle}`)")
        results = evaluate(scene, bundle, config)
    except (SceneError, ValueError, BundleError) as exc:
        print(f"impactnet evaluate: {exc}", file=sys.stderr)
        return EXIT_USAGE
    paths = write(results, args.out)
    _print_goals(results)
    print(f"wrote {', '.join(str(p) for p in paths)} in {results['seconds']:.1f} s")
    if args.check and not results["goals_met"]:
        return EXIT_GOAL_MISSED
    return EXIT_OK


def _run_compound(scene, args: argparse.Namespace) -> int:
    """`impactnet evaluate` on a scene of compound pairs
    (:mod:`impactnet.training.evaluate.compound`); ``--out`` defaults to
    docs/evaluation/<scene>."""
    from impactnet.training.evaluate.compound import evaluate_compound
    from impactnet.training.evaluate.compound_report import write

    bundle = args.bundle or f"models/bundles/{scene.name}"
    rows = args.rows or (200 if args.quick else 2000)
    out = args.out if args.out != DEFAULT_OUT else f"{DEFAULT_OUT}/{scene.name}"
    result = evaluate_compound(scene, bundle, rows, args.seed)
    paths = write(result, out)
    for p in result["pairs"]:
        goals = p.get("goals") or {}
        print(f"  {p['pair']}: serves {p['serve']}; goals "
              + (", ".join(f"{k} {'met' if v else 'MISSED'}" for k, v in goals.items())
                 or "not scored (no models)"))
    print(f"wrote {', '.join(str(p) for p in paths)} in {result['seconds']:.1f} s")
    return EXIT_GOAL_MISSED if args.check and not result["goals_met"] else EXIT_OK


def _print_goals(results: dict) -> None:
    """One line per goal of issue 4: measured value, bound, met / missed."""
    for g in results["goals"]:
        value = "-" if g["value"] is None else f"{g['value']:.4g}"
        print(f"  {g['predictor']} {g['goal']}: {value} {g['unit']} (goal {g['sense']} "
              f"{g['bound']:g}): {'met' if g['met'] else 'MISSED'}")
    print("goals of issue 4: " + ("all met" if results["goals_met"] else "some missed"))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="impactnet evaluate",
                                     description=__doc__.split("\n")[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
