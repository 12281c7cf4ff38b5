"""Timing and machine-recording helpers shared by every benchmark of impactnet.

One core: BLAS / OpenMP must be pinned to one thread before numpy is first imported
(:func:`pin_single_thread`; the CLI entry points call it first). Timed regions run with the
garbage collector paused; medians are reported and warm-up calls are never counted.
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
RECORDED_DISTRIBUTIONS = ("numpy", "scipy", "python-fcl", "torch", "matplotlib", "fastapi",
                          "uvicorn", "impactnet")


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


def median_per_call(fn: Callable, args_list: Sequence[tuple], warmup: int) -> tuple[float, int]:
    """Median seconds of ``fn(*args)`` over ``args_list``, not counting the first ``warmup``.

    Returns
    -------
    seconds : float
        Median wall time of one call.
    count : int
        Timed calls behind the median.
    """
    clock = time.perf_counter
    times = []
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for i, args in enumerate(args_list):
            t0 = clock()
            fn(*args)
            t1 = clock()
            if i >= warmup:
                times.append(t1 - t0)
    finally:
        if gc_was_enabled:
            gc.enable()
    return statistics.median(times), len(times)


def median_repeated(fn: Callable[[], object], repeats: int, warmup: bool = True) -> float:
    """Median seconds of ``fn()`` over ``repeats`` calls, after one warm-up call unless the
    caller has just made it (``warmup=False``)."""
    if warmup:
        fn()
    clock = time.perf_counter
    times = []
    gc_was_enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = clock()
            fn()
            times.append(clock() - t0)
    finally:
        if gc_was_enabled:
            gc.enable()
    return statistics.median(times)
