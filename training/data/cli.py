"""`impactnet datagen`: argument parsing and the command body, for impactnet/cli.py to wire in.

    impactnet datagen --scene quay_crane --n-per-pair 100000 --seed 0 --out data/ [--no-progress]

Writes ``<out>/<scene>.npz`` and ``<out>/<scene>.json`` (see :mod:`impactnet.training.data.datagen`)
and prints a one-line summary per pair plus the totals. Exit status: 0 done, 2 bad scene or
arguments.
"""
from __future__ import annotations

import argparse
import sys
import time

EXIT_OK = 0
EXIT_USAGE = 2


def _count(text: str) -> int:
    """A positive row count; accepts ``100000`` and ``1e5``."""
    try:
        value = float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from exc
    if value < 1 or value != int(value):
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return int(value)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `datagen` options to ``parser``."""
    parser.add_argument("--scene", default="quay_crane",
                        help="scene name (looked up in scenes/ or $IMPACTNET_SCENES_DIR) or "
                             "path to a .toml file (default: quay_crane)")
    parser.add_argument("--n-per-pair", type=_count, default=100_000,
                        help="labelled rows per pair of the scene (default: 100000)")
    parser.add_argument("--seed", type=int, default=0, help="dataset seed, >= 0 (default: 0)")
    parser.add_argument("--out", default="data", help="output folder (default: data/)")
    parser.add_argument("--separated-share", type=float, default=None,
                        help="share of separated (no contact) rows (default: 0.05)")
    parser.add_argument("--depth-fraction", type=float, nargs=2, metavar=("LO", "HI"),
                        default=None, help="override the scene's penetration depth range, "
                                           "fractions of the pair's shortest edge")
    parser.add_argument("--chunk-size", type=_count, default=None,
                        help="rows per vectorised step (changes the data; default: 65536)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Generate the dataset named by ``args``; returns the exit status."""
    from impactnet.models.scenes import SceneError, load_scene
    from impactnet.training.data.datagen import DatagenConfig, generate_dataset

    overrides = {"separated_share": args.separated_share, "chunk_size": args.chunk_size,
                 "depth_fraction": tuple(args.depth_fraction) if args.depth_fraction else None}
    try:
        scene = load_scene(args.scene)
        config = DatagenConfig(**{k: v for k, v in overrides.items() if v is not None})
        if args.seed < 0:
            raise ValueError(f"--seed must be >= 0, got {args.seed}")
    except (SceneError, ValueError) as exc:
        print(f"impactnet datagen: {exc}", file=sys.stderr)
        return EXIT_USAGE
    start = time.perf_counter()
    from impactnet.training.data.compound_dataset import compound_pairs

    if compound_pairs(scene):
        return _run_compound(scene, args, start)
    files = generate_dataset(scene, args.n_per_pair, args.seed, config, args.out,
                             progress=False if args.no_progress else None)
    seconds = time.perf_counter() - start
    _print_summary(files.manifest, seconds)
    print(f"wrote {files.npz} and {files.manifest_path}")
    return EXIT_OK


def _run_compound(scene, args: argparse.Namespace, start: float) -> int:
    """The dataset of a scene with compound bodies (its box pairs, if any, need a scene of
    their own: the learned side of compound pairs is issue #21)."""
    from impactnet.training.data.compound_dataset import (
        compound_pairs,
        generate_compound_dataset,
    )

    if len(compound_pairs(scene)) != len(scene.pairs):
        print("impactnet datagen: a scene mixing compound and box pairs is not supported yet; "
              "split it", file=sys.stderr)
        return EXIT_USAGE
    manifest = generate_compound_dataset(scene, args.n_per_pair, args.seed, args.out)
    seconds = time.perf_counter() - start
    for pair in manifest["pairs"]:
        print(f"  {pair['a']}/{pair['b']}: {pair['rows']} rows ({', '.join(pair['families'])}), "
              f"{pair['part_contacts']} part contacts")
    print(f"wrote {args.out}/{scene.name}.compound.npz and .json in {seconds:.1f} s")
    return EXIT_OK


def _print_summary(manifest: dict, seconds: float) -> None:
    """One line per pair: rows, contact-type shares, separated rows, regions seen."""
    print(f"scene {manifest['scene']['name']} (hash {manifest['scene']['hash'][:12]}), "
          f"seed {manifest['seed']}, generator {manifest['generator_version']}")
    for pair in manifest["pairs"]:
        types = ", ".join(f"{name} {count}" for name, count in pair["contact_types"].items()
                          if count and name != "none")
        print(f"  {pair['a']}/{pair['b']}: {pair['rows']} rows, separated "
              f"{pair['separated']}, {len(pair['regions'])} regions; {types}")
    rows = manifest["rows"]
    print(f"{rows} labelled pairs in {seconds:.1f} s ({rows / max(seconds, 1e-9):,.0f} pairs/s)")
