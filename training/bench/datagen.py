"""Throughput of labelled data generation on one core (a benchmark, not a test).

    python -m impactnet.training.bench.datagen [--quick] [--scene quay_crane] [--seed 0]

What is measured
----------------
* ``generate_pairs``: N labelled rows (poses drawn by ``first_contact_poses`` in the default
  family shares, labels from ``impactnet.models.box.exact.box_box``) of one pair, the 20 ft / 40 ft
  containers, for N = 1e5 and 1e6 (1e5 only with ``--quick``). One untimed warm-up call of
  1e4 rows comes first.
* ``generate_dataset``: the same N spread evenly over the scene's pairs, end to end: drawing,
  labelling, writing the deterministic ``.npz`` (to a temporary folder), hashing it and writing
  the manifest.

The goal (issue 3) is 1 million labelled pairs in under a minute on one core. BLAS / OpenMP are
pinned to one thread before numpy is imported. The exact solver is being optimised
concurrently, so the figure moves with it.
"""
from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"  # before numpy is imported anywhere

import argparse  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

from impactnet.models.scenes import load_scene  # noqa: E402
from impactnet.training.data.datagen import DatagenConfig, generate_dataset, generate_pairs  # noqa: E402

#: Issue 3's goal: seconds for 1 million labelled pairs on one core.
GOAL_SECONDS_PER_MILLION = 60.0
#: The pair timed by the generate_pairs rows: ISO 20 ft and 40 ft containers, metres.
PAIR = ((6.058, 2.438, 2.591), (12.192, 2.438, 2.591))
WARMUP_ROWS = 10_000


def time_generate_pairs(n: int, seed: int) -> tuple[int, float]:
    """(rows, seconds) of ``generate_pairs`` of n rows of :data:`PAIR`."""
    start = time.perf_counter()
    generate_pairs(*PAIR, n, seed, DatagenConfig(), progress=False)
    return n, time.perf_counter() - start


def time_generate_dataset(scene_name: str, n: int, seed: int) -> tuple[int, float]:
    """(rows, seconds) of ``generate_dataset`` of about n rows over the scene's pairs."""
    scene = load_scene(scene_name)
    per_pair = max(1, n // len(scene.pairs))
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        generate_dataset(scene, per_pair, seed, DatagenConfig(), folder, progress=False)
        return per_pair * len(scene.pairs), time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="N = 1e5 only")
    parser.add_argument("--scene", default="quay_crane", help="scene of the dataset rows")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    print(f"# datagen throughput, one thread ({platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()})\n")
    time_generate_pairs(WARMUP_ROWS, args.seed)
    sizes = (100_000,) if args.quick else (100_000, 1_000_000)
    print("| what | N | seconds | labelled pairs/s | 1e6 pairs in |")
    print("|---|---:|---:|---:|---:|")
    for n in sizes:
        for label, (rows, seconds) in (
                ("generate_pairs (20 ft / 40 ft)", time_generate_pairs(n, args.seed)),
                (f"generate_dataset ({args.scene}, with files)",
                 time_generate_dataset(args.scene, n, args.seed))):
            rate = rows / seconds
            print(f"| {label} | {rows:,} | {seconds:.2f} | {rate:,.0f} | "
                  f"{1e6 / rate:.1f} s |")
    print(f"\ngoal: 1e6 labelled pairs in under {GOAL_SECONDS_PER_MILLION:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
