"""Predictors of this checkout against an earlier one: N = 1 and batch, same poses, same session.

    python -m impactnet.training.bench.exact.baseline_modes --baseline ../base [--modes exact,auto]

A refactoring issue's "no worse" is a relative claim, so both checkouts are timed here, in
child processes (one thread each), alternately, for ``--rounds`` rounds, on the same scene
first-contact poses (``--scene``, written once to a temporary ``.npz``). Per mode each child
reports the median of single-pair calls (after a warm-up) and the median of five batched calls
of ``--batch`` pairs; the figures quoted are the medians over the rounds. The child loads
``load_predictor`` from the checkout it is given, in either layout (see
:mod:`impactnet.training.bench.exact.baseline`), with the checkout's own shipped bundle.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

from impactnet.training.bench.exact.baseline import LAYOUT_SHIM, run_child

#: Single-pair calls per child and mode (the first WARMUP are not timed).
SINGLE_CALLS, WARMUP = 2000, 200

_CHILD = LAYOUT_SHIM + r"""
import gc, json, statistics, time
import numpy as np
if LAYOUT == "namespace":
    from impactnet.models import load_predictor
else:
    from models import load_predictor
data = np.load(sys.argv[1])
single_calls, warmup, batch = (int(v) for v in sys.argv[3:6])
keys = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
args = tuple(data[k] for k in keys)
out = {}
for mode in sys.argv[2].split(","):
    predictor = load_predictor(mode)
    singles = [tuple(a[i] for a in args) for i in range(single_calls)]
    for pair in singles[:warmup]:
        predictor(*pair)
    gc.disable()
    times = []
    for pair in singles[warmup:]:
        start = time.perf_counter(); predictor(*pair); times.append(time.perf_counter() - start)
    block = tuple(a[:batch] for a in args)
    predictor(*block)
    batches = []
    for _ in range(5):
        start = time.perf_counter(); predictor(*block); batches.append(time.perf_counter() - start)
    gc.enable()
    out[mode] = {"n1_us": 1e6 * statistics.median(times),
                 "batch_us_per_pair": 1e6 * statistics.median(batches) / batch}
print(json.dumps(out))
"""


def compare(baseline: Path, current: Path, modes: str, scene: str, batch: int, rounds: int,
            log=print) -> dict:
    """Per side and mode, the medians over ``rounds`` of ``n1_us`` and ``batch_us_per_pair``."""
    from impactnet.models.scenes import load_scene
    from impactnet.training.bench.pose_sets import scene_poses

    keys = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
    poses = scene_poses(load_scene(scene), max(batch, SINGLE_CALLS), 0)
    runs: dict[str, list[dict]] = {"baseline": [], "current": []}
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "poses.npz")
        np.savez(path, **dict(zip(keys, poses.args())))
        for index in range(rounds):
            for side, root in (("baseline", baseline), ("current", current)):
                runs[side].append(run_child(root.resolve(), _CHILD, path, modes,
                                            SINGLE_CALLS, WARMUP, batch))
            log(f"round {index + 1}/{rounds}: {json.dumps(runs)}")
    return {side: {mode: {key: statistics.median(r[mode][key] for r in results)
                          for key in ("n1_us", "batch_us_per_pair")}
                   for mode in modes.split(",")} for side, results in runs.items()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.training.bench.exact.baseline_modes",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--baseline", required=True, help="an earlier checkout")
    parser.add_argument("--modes", default="exact,auto", help="comma-separated predictors")
    parser.add_argument("--scene", default="quay_crane", help="scene of the poses")
    parser.add_argument("--batch", type=int, default=100_000, help="pairs per batched call")
    parser.add_argument("--rounds", type=int, default=3, help="alternated rounds")
    args = parser.parse_args(argv)
    current = Path(__file__).resolve().parents[2]
    result = compare(Path(args.baseline), current, args.modes, args.scene, args.batch,
                     args.rounds, log=lambda m: print(m, file=sys.stderr))
    print("| mode | N = 1 µs, baseline -> current | batch µs/pair, baseline -> current |")
    print("|---|---:|---:|")
    for mode in args.modes.split(","):
        b, c = result["baseline"][mode], result["current"][mode]
        one, many = b["batch_us_per_pair"], c["batch_us_per_pair"]
        print(f"| {mode} | {b['n1_us']:.1f} -> {c['n1_us']:.1f} "
              f"({c['n1_us'] / b['n1_us']:.2f}x) | {one:.3f} -> {many:.3f} ({many / one:.2f}x) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
