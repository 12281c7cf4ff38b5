"""``impactnet bench frame``: the scaling of a frame, its speed against MuJoCo in process and
over HTTP, and where its time goes, measured in one run; writes ``frame.md``, ``frame.json``
and the scaling figure.

    impactnet bench frame --out docs/benchmarks --plot docs/images/frame_scaling.png

The compiled kernels run on :data:`DEFAULT_THREADS` thread unless ``--threads`` says otherwise
(MuJoCo runs on one; the server started for the HTTP section gets the same count), BLAS is
pinned to one thread, medians are quoted (with the best call beside them where the machine is
shared), warm-up calls are never counted.
"""
from __future__ import annotations

import datetime
import json
import os
import sys
import time
from pathlib import Path

from impactnet.training.bench.frame import report
from impactnet.training.bench.frame.scaling import QUICK_SCALING, ScalingPlan
from impactnet.training.bench.frame.speed import QUICK_FRAME, FramePlan

#: The kernels' threads of the run: one, like MuJoCo's collision from Python.
DEFAULT_THREADS = 1


def _log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def measure(quick: bool, seed: int, http: bool, log=_log) -> dict:
    """Every section's figures as plain JSON types."""
    from impactnet.training.bench.accuracy.vs_mujoco import mujoco_missing
    from impactnet.training.bench.frame import scaling, speed
    from impactnet.training.bench.speed.box_pairs import warm_kernels

    warm_kernels(log)
    out: dict = {"scaling": scaling.measure(QUICK_SCALING if quick else ScalingPlan(), seed,
                                            log)}
    missing = mujoco_missing()
    if missing is not None:
        out["speed"] = {"error": f"MuJoCo not available: {missing}"}
        return out
    import mujoco

    out["mujoco"] = f"MuJoCo {mujoco.__version__}"
    plan = QUICK_FRAME if quick else FramePlan()
    measured = speed.measure(plan, seed, log)
    yards = measured.pop("yards")
    out["speed"] = measured
    if http:
        from impactnet.training.bench.frame.frame_http import measure_http

        out["http"] = measure_http(yards, plan, log)
    return out


def run(quick: bool, out: Path, plot: Path | None, seed: int = 0, http: bool = True,
        threads: int | None = DEFAULT_THREADS, command: str = "impactnet bench frame",
        log=_log) -> int:
    """The benchmark (module docstring); prints the Markdown. Returns 0."""
    from impactnet.training.bench.frame.plot import plot_scaling
    from impactnet.training.bench.speed.box_pairs import kernel_threads
    from impactnet.training.bench.timing import machine_info

    started = time.perf_counter()
    set_to = kernel_threads(threads)
    if set_to is not None:
        os.environ["IMPACTNET_KERNEL_THREADS"] = str(set_to)  # the HTTP section's server
    machine = machine_info()
    results = {"created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
               "mode": "quick" if quick else "full", "seed": seed, "command": command,
               "kernel_threads": set_to, "machine": machine,
               **measure(quick, seed, http, log)}
    results["load_avg_1m_end"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    results["seconds"] = round(time.perf_counter() - started, 1)
    out.mkdir(parents=True, exist_ok=True)
    figure = plot if plot is not None else out / "frame_scaling.png"
    plot_scaling(results["scaling"], figure, command)
    text = report.markdown(results, os.path.relpath(figure, out))
    (out / "frame.md").write_text(text, encoding="utf-8")
    (out / "frame.json").write_text(json.dumps(results, indent=1, allow_nan=False),
                                    encoding="utf-8")
    print(text)
    log(f"impactnet bench frame: wrote {out / 'frame.md'}, {out / 'frame.json'}, {figure} in "
        f"{results['seconds']} s")
    return 0
