"""`impactnet train`: argument parsing and the command body, for impactnet/cli.py to wire in.

    impactnet train --scene quay_crane --out models/bundles/quay_crane --seed 0 [--quick]
                    [--workers 2] [--no-progress] [--no-reuse] [--cache DIR]
                    [--no-gate] [--max-fallback-share F] [--keep N]

Trains the learned models of the scene's pairs into a new version of the bundle store ``--out``
(:mod:`impactnet.training.jobs.retrain`): unchanged pairs are reused from the per-pair cache, or
where it has none from the store's current bundle (said on stderr), a rerun after an interruption
resumes from the finished pairs, each pair is decided learned or exact-only
(:mod:`impactnet.training.jobs.decisions`: fast enough and within the scene's tolerance, or not,
said on stderr with the reasons), and the ``current`` pointer moves to the new version only when it
passes the validation gate (:mod:`impactnet.training.fit.validation_gate`: what the bundle serves
within the scene's p99 tolerances). Prints one line per pair (test figures), the gate's verdict and
the wall time.

Exit status: 0 published; 2 bad scene or arguments; 3 the gate refused the new version
(``current`` untouched); 130 interrupted (finished pairs cached: rerun to resume).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time

EXIT_OK = 0
EXIT_USAGE = 2
EXIT_GATE = 3
EXIT_INTERRUPTED = 130


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `train` options to ``parser``."""
    parser.add_argument("--scene", default="quay_crane",
                        help="scene name (looked up in scenes/ or $IMPACTNET_SCENES_DIR) or "
                             "path to a .toml file (default: quay_crane)")
    parser.add_argument("--out", default=None,
                        help="bundle store to write a new version into (default: "
                             "models/bundles/<scene>)")
    parser.add_argument("--seed", type=int, default=0,
                        help="data and torch seed, >= 0 (default: 0)")
    parser.add_argument("--quick", action="store_true",
                        help="tiny data and epochs, a few seconds per pair (smoke runs, tests)")
    parser.add_argument("--workers", type=int, default=None,
                        help="pairs trained in parallel processes (default: 2; quick: 1)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.add_argument("--no-reuse", action="store_true",
                        help="retrain every pair, even unchanged ones: nothing is taken from "
                             "the cache or the current bundle (the cache is refreshed)")
    parser.add_argument("--cache", default=None,
                        help="per-pair cache folder (default: <out>/.cache/pairs)")
    parser.add_argument("--no-gate", action="store_true",
                        help="publish the new version even if it fails the validation gate "
                             "(the verdict is still recorded in its manifest)")
    parser.add_argument("--max-fallback-share", type=float, default=1.0,
                        help="gate: largest share of a pair's test rows that auto may hand to "
                             "the exact solver (default: 1.0, no bound)")
    parser.add_argument("--rows", type=int, default=None,
                        help="compound scenes: labelled first-contact rows per pair (default: "
                             "16000; quick: 1500)")
    parser.add_argument("--data", default=None,
                        help="compound scenes: folder of the labelled rows (`impactnet datagen` "
                             "output; labelled and written there when missing; default: data/)")
    parser.add_argument("--keep", type=int, default=None,
                        help="accepted versions kept in the store, the current one included "
                             "(default: 5)")


def _job_config(args: argparse.Namespace):
    """The :class:`impactnet.training.jobs.retrain.JobConfig` of the arguments (ValueError when
    bad)."""
    from pathlib import Path

    from impactnet.training.fit.validation_gate import GateConfig
    from impactnet.training.jobs.retrain import KEEP_VERSIONS, JobConfig

    if not 0.0 <= args.max_fallback_share <= 1.0:
        raise ValueError(f"--max-fallback-share must be in [0, 1], got {args.max_fallback_share}")
    keep = KEEP_VERSIONS if args.keep is None else args.keep
    if keep < 1:
        raise ValueError(f"--keep must be >= 1, got {keep}")
    return JobConfig(reuse=not args.no_reuse,
                     cache_dir=Path(args.cache) if args.cache else None,
                     gate=GateConfig(max_fallback_share=args.max_fallback_share),
                     enforce_gate=not args.no_gate, keep_versions=keep)


def run(args: argparse.Namespace) -> int:
    """Train the scene named by ``args`` into a new store version; returns the exit status."""
    from impactnet.models.scenes import SceneError, load_scene
    from impactnet.training.data.compound_dataset import is_compound_scene
    from impactnet.training.fit.pair import PairTrainConfig
    from impactnet.training.jobs.retrain import run_train_job
    from impactnet.training.jobs.scene import TrainConfig, quick_config

    try:
        scene = load_scene(args.scene)
        if is_compound_scene(scene):
            return _run_compound(scene, args)
        scene.require_box_pairs("impactnet train")  # a scene mixing both is not supported
        if args.seed < 0:
            raise ValueError(f"--seed must be >= 0, got {args.seed}")
        if args.workers is not None and args.workers < 1:
            raise ValueError(f"--workers must be >= 1, got {args.workers}")
        job = _job_config(args)
    except (SceneError, ValueError) as exc:
        print(f"impactnet train: {exc}", file=sys.stderr)
        return EXIT_USAGE
    config = (quick_config(args.seed) if args.quick
              else TrainConfig(pair=PairTrainConfig(seed=args.seed)))
    if args.workers is not None:
        config = dataclasses.replace(config, workers=args.workers)
    out = args.out or f"models/bundles/{scene.name}"
    start = time.perf_counter()
    try:
        outcome = run_train_job(scene, out, config, job,
                                progress=False if args.no_progress else None)
    except KeyboardInterrupt:
        print(f"impactnet train: interrupted; finished pairs are cached, '{out}/current' is "
              "unchanged: run the same command again to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    _print_summary(outcome.manifest, time.perf_counter() - start)
    return _report_outcome(outcome, out)


def _run_compound(scene, args: argparse.Namespace) -> int:
    """`impactnet train` for a scene of compound pairs (:mod:`impactnet.training.compound`)."""
    from impactnet.training.compound.scene import ROWS_PER_PAIR, train_compound_scene
    from impactnet.training.compound.settings import compound_config

    rows = args.rows or (1500 if args.quick else ROWS_PER_PAIR)
    if args.seed < 0 or rows < 100:
        print("impactnet train: --seed must be >= 0 and --rows >= 100", file=sys.stderr)
        return EXIT_USAGE
    out = args.out or f"models/bundles/{scene.name}"
    start = time.perf_counter()
    try:
        path, manifest = train_compound_scene(
            scene, out, compound_config(args.seed, args.quick), rows, args.data or "data",
            log=lambda m: print(f"train: {m}", file=sys.stderr, flush=True))
    except KeyboardInterrupt:
        print(f"impactnet train: interrupted; '{out}/current' is unchanged", file=sys.stderr)
        return EXIT_INTERRUPTED
    for key, entry in manifest["compound_pairs"].items():
        decision = entry["decision"]
        print(f"  {key}: {decision['serve']}"
              + (f" ({'; '.join(decision['reasons'])})" if decision["reasons"] else ""))
    print(f"wrote {path} (version {manifest['version']}); {out}/current -> "
          f"{manifest['version']} in {time.perf_counter() - start:.0f} s")
    return EXIT_OK


def _report_outcome(outcome, out) -> int:
    """The gate's verdict and where the version went; the exit status."""
    gate = outcome.gate
    if outcome.reused:
        print(f"reused {len(outcome.reused)} unchanged pairs: {', '.join(outcome.reused)}")
    if gate.passed:
        print(f"validation gate passed ({len(gate.checks)} checks)")
    else:
        print("validation gate FAILED:\n  " + "\n  ".join(gate.failures),
              file=sys.stderr)
    if outcome.published:
        before = outcome.previous or "none"
        print(f"wrote {outcome.path} (version {outcome.version}); {out}/current: {before} -> "
              f"{outcome.version}")
        return EXIT_OK
    print(f"impactnet train: version {outcome.version} refused by the validation gate, kept in "
          f"{outcome.path}; {out}/current still names {outcome.previous or 'nothing'} "
          "(--no-gate publishes anyway)", file=sys.stderr)
    return EXIT_GATE


def _number(value, scale: float = 1.0, digits: int = 3) -> str:
    """A figure for the summary; "-" where there was nothing to measure (None)."""
    return "-" if value is None else f"{scale * value:.{digits}f}"


def _print_summary(manifest: dict, seconds: float) -> None:
    """One line per pair with its test figures, then the wall time."""
    for key, pair in manifest["pairs"].items():
        test = pair["test"]
        normal, point = test["committee"]["normal_deg"], test["committee"]["point_fraction"]
        auto = test["auto"]
        print(f"  {key}: region acc {test['region_accuracy']:.4f}; committee normal median "
              f"{_number(normal['median'])} deg, mean {_number(normal['mean'])} deg, point "
              f"median {_number(point['median'], 100, 2)} %, mean "
              f"{_number(point['mean'], 100, 2)} %; auto fallback "
              f"{100 * auto['fallback_share']:.1f} %, p99 normal "
              f"{_number(auto['normal_deg']['p99'])} deg, p99 point "
              f"{_number(auto['point_fraction']['p99'], 100, 2)} %")
    print(f"trained {len(manifest['pairs'])} pairs in {seconds:.0f} s")
