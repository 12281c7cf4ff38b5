"""Timing and machine-recording helpers shared by every benchmark of impactnet.

One core: BLAS / OpenMP must be pinned to one thread before numpy is first imported
(:func:`pin_single_thread`; the CLI entry points call it first). Timed regions run with the
garbage collector paused; medians are reported and warm-up calls are never counted. Two
things compared in one run (ours and MuJoCo, say) are timed in alternating slices
(:func:`alternated`), so that a slow spell of a shared machine falls on both.
"""
from __future__ import annotations

import gc
import os
import platform
import statistics
import time
from collections.abc import Callable, Sequence
from importlib import metadata

#: Environment variables that set the thread count of BLAS / OpenMP (read once, at load time).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
#: Distributions whose versions are recorded with the results.
RECORDED_DISTRIBUTIONS = ("numpy", "scipy", "numba", "python-fcl", "mujoco", "torch",
                          "matplotlib", "fastapi", "uvicorn", "impactnet")


def pin_single_thread() -> bool:
    """Ask BLAS / OpenMP for one thread; False if numpy was already imported (too late)."""
    import sys

    for name in THREAD_VARIABLES:
        os.environ[name] = "1"
    return "numpy" not in sys.modules


def _cpu_model() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return cpu


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def machine_info() -> dict:
    """CPU model, core counts, load, Python and the library versions behind the figures."""
    import numpy as np

    return {
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "cores_usable": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "load_avg_1m": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "numpy": np.__version__,
        "python-fcl": _version("python-fcl"),
        "impactnet": _version("impactnet"),
        "versions": {dist: _version(dist) for dist in RECORDED_DISTRIBUTIONS},
        "threads": {name: os.environ.get(name) for name in THREAD_VARIABLES},
    }


def call_times(calls: Sequence[tuple[Callable, tuple]], warmup: int) -> list[float]:
    """Seconds of each ``fn(*args)`` of ``calls`` (``(fn, args)`` pairs, each call timed on its
    own, the collector paused), not counting the first ``warmup``."""
    clock = time.perf_counter
    times = []
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for i, (fn, args) in enumerate(calls):
            t0 = clock()
            fn(*args)
            t1 = clock()
            if i >= warmup:
                times.append(t1 - t0)
    finally:
        if gc_was_enabled:
            gc.enable()
    return times


def median_per_call(fn: Callable, args_list: Sequence[tuple], warmup: int) -> tuple[float, int]:
    """Median seconds of ``fn(*args)`` over ``args_list``, not counting the first ``warmup``.

    Returns
    -------
    seconds : float
        Median wall time of one call.
    count : int
        Timed calls behind the median.
    """
    times = call_times([(fn, args) for args in args_list], warmup)
    return statistics.median(times), len(times)


def median_repeated(fn: Callable[[], object], repeats: int, warmup: bool = True) -> float:
    """Median seconds of ``fn()`` over ``repeats`` calls, after one warm-up call unless the
    caller has just made it (``warmup=False``)."""
    if warmup:
        fn()
    return statistics.median(call_times([(fn, ())] * repeats, 0))


def alternated(first: Sequence[tuple[Callable, tuple]], second: Sequence[tuple[Callable, tuple]],
               warmup: int, rounds: int = 3) -> tuple[float, float]:
    """Median seconds per call of two call lists (``(fn, args)`` pairs) timed in alternating
    slices (``rounds`` of each), so that a slow spell of a shared machine falls on both; the
    first ``warmup`` calls of each list are not counted."""
    for calls in (first, second):
        call_times(calls[:warmup], warmup)  # the warm-up calls, none kept
    times: tuple[list, list] = ([], [])
    for r in range(rounds):
        for calls, out in zip((first, second), times):
            body = calls[warmup:]
            out += call_times(body[r * len(body) // rounds:(r + 1) * len(body) // rounds], 0)
    return statistics.median(times[0]), statistics.median(times[1])
