"""N = 1 speed of the exact solver against an earlier checkout, same session, same poses.

    impactnet bench exact --baseline ../base      # ../base: e.g. `git worktree add ../base REV`

The speed budget of the exact solver at N = 1 is relative ("within 1.5x of the commit before
this work"), because absolute microseconds vary from machine to machine. Both checkouts are
timed here in child processes, one thread each, alternately (baseline, current, baseline, ...),
on the same poses written once to a temporary ``.npz``; each child reports the median of its
single-pair calls and the figure quoted is the median over the rounds. Alternating spreads a
change of machine load over both sides instead of charging it to one.

The child imports ``box_box`` from the checkout it is given, whatever its layout: under the
``impactnet`` namespace (``impactnet.models.box.exact``, the package's path pointed at the
checkout rather than at what is installed) or from the flat layout before it
(``models.exact``, with ``PYTHONPATH`` set to the checkout), so that any commit with that
function can serve as the baseline.
"""
from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

#: Rounds of (baseline, current) pairs; the reported figure is the median over rounds.
ROUNDS = 3
#: Warm-up single calls of each child before timing.
WARMUP_CALLS = 200
#: Wall-clock limit of one child, seconds (a few thousand calls take a few seconds).
CHILD_TIMEOUT_S = 300.0

#: Child-process preamble: the checkout in the working directory as ``impactnet`` (its
#: namespace layout; the package's path pointed at the checkout, not at what is installed),
#: and ``LAYOUT`` saying which layout it has ("flat" before the namespace).
LAYOUT_SHIM = r"""
import os, sys, types
root = os.getcwd()
LAYOUT = "namespace" if os.path.isdir(os.path.join(root, "models", "box")) else "flat"
if LAYOUT == "namespace":
    package = types.ModuleType("impactnet")
    package.__path__ = [os.path.join(root, "impactnet"), root]
    sys.modules["impactnet"] = package
"""

_CHILD = LAYOUT_SHIM + r"""
import gc, json, statistics, time
import numpy as np
if LAYOUT == "namespace":
    from impactnet.models.box.exact import box_box
else:
    from models.exact import box_box
data = np.load(sys.argv[1])
keys = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
pairs = list(zip(*(data[k] for k in keys)))
warmup = int(sys.argv[2])
for pair in pairs[:warmup]:
    box_box(*pair)
times = []
gc.disable()
for pair in pairs[warmup:]:
    start = time.perf_counter()
    box_box(*pair)
    times.append(time.perf_counter() - start)
gc.enable()
print(json.dumps({"median_s": statistics.median(times), "calls": len(times)}))
"""


def run_child(checkout: Path, code: str, *args) -> dict:
    """Run the timing ``code`` (a ``python -c`` script starting with :data:`LAYOUT_SHIM`) in
    ``checkout``, one thread, and return the JSON its last line prints."""
    env = dict(os.environ, PYTHONPATH=str(checkout), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=checkout, env=env,
                          capture_output=True, text=True, timeout=CHILD_TIMEOUT_S, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"timing child in {checkout} failed: {done.stderr.strip()[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def compare_single_pair(poses: dict, calls: int, baseline: Path, current: Path,
                        rounds: int = ROUNDS, log=print) -> dict:
    """Median microseconds per N = 1 call of both checkouts on the first ``calls`` poses.

    Parameters
    ----------
    poses : dict
        Pose columns (``size_a`` (n, 3), ``position_a`` (n, 3), ``quaternion_a`` (n, 4), the
        same for b), n >= ``calls``.
    calls : int
        Single-pair calls per child, warm-up included.
    baseline, current : Path
        Repository roots (each with ``models/box/exact.py``).

    Returns
    -------
    dict
        ``baseline_us`` and ``current_us`` (median over rounds), ``ratio`` (current /
        baseline), ``rounds`` and the per-round figures.
    """
    keys = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
    per_round: dict[str, list[float]] = {"baseline": [], "current": []}
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "poses.npz")
        np.savez(path, **{k: np.asarray(poses[k][:calls], dtype=np.float64) for k in keys})
        for index in range(rounds):
            for side, root in (("baseline", baseline), ("current", current)):
                seconds = run_child(root.resolve(), _CHILD, path,
                                    min(WARMUP_CALLS, calls // 4))["median_s"]
                per_round[side].append(1e6 * seconds)
            log(f"N = 1 round {index + 1}/{rounds}: baseline {per_round['baseline'][-1]:.1f} "
                f"µs, current {per_round['current'][-1]:.1f} µs")
    baseline_us = statistics.median(per_round["baseline"])
    current_us = statistics.median(per_round["current"])
    return {"baseline": str(baseline), "baseline_us": baseline_us, "current_us": current_us,
            "ratio": current_us / baseline_us, "rounds": rounds, "per_round_us": per_round}
