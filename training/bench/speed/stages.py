"""The per-stage profile's interface: a solver's stages as ``name -> zero-argument callable``,
each doing its stage's work on inputs prepared beforehand, timed one by one.

:func:`time_stages` warms every stage up once, then times them in rounds (one call of each
stage per round, so that a slow spell of a shared machine falls on all of them) and keeps each
stage's median. ``whole``, the public entry on the same inputs, is timed in the same rounds;
the profile's last line, "rest", is ``whole`` minus the sum of the stages: the glue, the output
arrays and whatever no stage covers (a few per cent negative at most, by noise). A stage whose
name starts with :data:`PART_OF` is part of the stage above it: shown, not summed.

Where the stages come from is :mod:`impactnet.training.bench.speed.stage_sources`'s business: a
kernel stage is any zero-argument callable, so switching to the compiled kernels changes the
sources, not this module.
"""
from __future__ import annotations

import statistics
from collections.abc import Callable, Mapping

from impactnet.training.bench.speed.ratios import figure
from impactnet.training.bench.timing import call_times

Stage = Callable[[], object]
#: Prefix of a stage that is part of the stage above it (not summed).
PART_OF = "· "
#: The profile's line of what no stage covers.
REST = "rest (what no stage covers)"


def time_stages(stages: Mapping[str, Stage], repeats: int,
                whole: Stage | None = None) -> tuple[dict[str, float], float | None]:
    """Median seconds of each stage (and of ``whole``) over ``repeats`` rounds, after one
    warm-up call each (module docstring)."""
    calls = dict(stages)
    if whole is not None:
        calls[None] = whole
    for fn in calls.values():
        fn()
    times: dict = {name: [] for name in calls}
    for _ in range(repeats):
        for name, fn in calls.items():
            times[name] += call_times([(fn, ())], 0)
    medians = {name: statistics.median(values) for name, values in times.items()}
    return {name: medians[name] for name in stages}, medians.get(None)


def profile(solver: str, unit: str, units: int, build: Callable[[], tuple], repeats: int) -> dict:
    """One solver's profile as plain JSON types: ``build()`` gives ``(stages, whole)``; a
    source that fails to build or run (a stage function renamed, gone or changed while the
    kernels replace it) gives a note instead of figures, and the benchmark goes on."""
    out = {"solver": solver, "unit": unit, "units": units, "repeats": repeats}
    try:
        stages, whole = build()
        seconds, whole_s = time_stages(stages, repeats, whole)
    except Exception as exc:  # noqa: BLE001 - the profile must not stop the benchmark
        out["note"] = (f"stage functions not available ({type(exc).__name__}: {exc}); switch "
                       "the source in training/bench/speed/stage_sources.py")
        return out
    out["stages"] = {name: 1e6 * s / units for name, s in seconds.items()}  # µs per unit
    out["whole_us"] = None if whole_s is None else 1e6 * whole_s / units
    if whole_s is not None:
        summed = sum(s for name, s in seconds.items() if not name.startswith(PART_OF))
        out["stages"][REST] = 1e6 * (whole_s - summed) / units
    return out


def table(profiles: list[dict]) -> str:
    """Markdown: one block of lines per solver (µs per unit and share of the whole)."""
    lines = ["| solver | stage | µs per unit | share of the whole |", "|---|---|---:|---:|"]
    for p in profiles:
        head = f"{p['solver']} ({p['units']:,} {p['unit']}s)"
        if "note" in p:
            lines.append(f"| {head} | {p['note']} | – | – |")
            continue
        whole = p.get("whole_us")
        for name, us in p["stages"].items():
            share = f"{100 * us / whole:.0f} %" if whole else "–"
            lines.append(f"| {head} | {name} | {figure(us)} | {share} |")
            head = ""
        if whole is not None:
            lines.append(f"| | **whole (public entry)** | {figure(whole)} | 100 % |")
    return "\n".join(lines)
