"""`impactnet train`: argument parsing and the command body, for impactnet/cli.py to wire in.

    impactnet train --scene quay_crane --out models/bundles/quay_crane --seed 0 [--quick]
                    [--workers 2] [--no-progress]

Trains the learned models of every pair of the scene (:mod:`training.train`) and writes the
bundle folder atomically; prints one line per pair (test-split region accuracy, committee and
auto figures) and the wall time. Exit status: 0 done, 2 bad scene or arguments.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time

EXIT_OK = 0
EXIT_USAGE = 2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `train` options to ``parser``."""
    parser.add_argument("--scene", default="quay_crane",
                        help="scene name (looked up in scenes/ or $IMPACTNET_SCENES_DIR) or "
                             "path to a .toml file (default: quay_crane)")
    parser.add_argument("--out", default=None,
                        help="bundle folder to write (default: models/bundles/<scene>)")
    parser.add_argument("--seed", type=int, default=0,
                        help="data and torch seed, >= 0 (default: 0)")
    parser.add_argument("--quick", action="store_true",
                        help="tiny data and epochs, a few seconds per pair (smoke runs, tests)")
    parser.add_argument("--workers", type=int, default=None,
                        help="pairs trained in parallel processes (default: 2; quick: 1)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    """Train the scene named by ``args`` into a bundle; returns the exit status."""
    from models.scenes import SceneError, load_scene
    from training.train import TrainConfig, quick_config, train_scene
    from training.train_pair import PairTrainConfig

    try:
        scene = load_scene(args.scene)
        if args.seed < 0:
            raise ValueError(f"--seed must be >= 0, got {args.seed}")
        if args.workers is not None and args.workers < 1:
            raise ValueError(f"--workers must be >= 1, got {args.workers}")
    except (SceneError, ValueError) as exc:
        print(f"impactnet train: {exc}", file=sys.stderr)
        return EXIT_USAGE
    config = (quick_config(args.seed) if args.quick
              else TrainConfig(pair=PairTrainConfig(seed=args.seed)))
    if args.workers is not None:
        config = dataclasses.replace(config, workers=args.workers)
    out = args.out or f"models/bundles/{scene.name}"
    start = time.perf_counter()
    path, manifest = train_scene(scene, out, config,
                                 progress=False if args.no_progress else None)
    _print_summary(manifest, time.perf_counter() - start)
    print(f"wrote {path} (version {manifest['version']})")
    return EXIT_OK


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
