"""``box_box`` against MuJoCo 4 on one pose set of box pairs, both timed in the same run.

* N = 1: the public ``impactnet.models.box.exact.box_box`` on one pair per call (six 1-D
  arrays in, the ``Contacts`` out: input checks included), against MuJoCo's one pair from
  Python (:func:`impactnet.training.bench.speed.mujoco_calls.box_pair_call`: qpos in,
  ``mj_kinematics``, ``mj_collision``, the contacts' pos, frame and dist out as arrays), on the
  same distinct poses spread over the set; the two timed in alternating slices, each call on
  its own, medians (:func:`impactnet.training.bench.timing.alternated`).
* Batch: ``box_box`` on the whole set in one call (six (n, .) arrays in, the ``Contacts`` out) with
  the kernels' threads at the machine's cores, and at one thread
  (:func:`impactnet.models.compiled.set_threads`); against MuJoCo's C rate: ``mj_collision`` per
  pair over blocks of 1,000 explicit pairs
  (:class:`impactnet.training.bench.speed.mujoco_calls.ExplicitPairs`; ``mj_kinematics`` per pair
  recorded beside it). Repeats alternate the three; medians.

Ratios are ours / MuJoCo as time per pair (:mod:`impactnet.training.bench.speed.ratios`).
"""
from __future__ import annotations

import statistics

import numpy as np

from impactnet.training.bench.speed import ratios as rt
from impactnet.training.bench.timing import alternated, call_times


def kernel_threads(count: int | None = None) -> int | None:
    """Set the compiled kernels' threads (None: their default, the usable cores); the number
    set, or None where the compiled core is missing."""
    try:
        from impactnet.models.compiled import set_threads
    except ImportError:
        return None
    return set_threads(count)


def warm_kernels(log=lambda message: None) -> None:
    """Compile or load every compiled kernel before any clock starts
    (:func:`impactnet.models.compiled.warm_up`; nothing where the compiled core is missing)."""
    import time

    try:
        from impactnet.models.compiled import warm_up
    except ImportError:
        return
    started = time.perf_counter()
    count = warm_up()
    log(f"  kernels: {count} warm-ups in {time.perf_counter() - started:.1f} s")


def usable_cores() -> int:
    """The cores this process may run on."""
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def one_pair(poses, calls: int, warmup: int, rounds: int) -> dict:
    """N = 1 on ``calls`` poses spread over ``poses`` (after ``warmup`` more): µs per call of
    ``box_box`` and of MuJoCo from Python, and their ratio."""
    from impactnet.models.box.exact import box_box
    from impactnet.training.bench.speed.mujoco_calls import box_pair_call

    rows = poses.subsample(calls + warmup)
    warmup = min(warmup, len(rows) // 4)
    ours, theirs, callers = [], [], {}
    for i in rows:
        args = poses.pair_args(int(i))
        key = (*args[0], *args[3])
        if key not in callers:  # one model per pair of sizes, built before any clock starts
            callers[key] = box_pair_call(args[0], args[3])
        ours.append((box_box, args))
        theirs.append((callers[key], (args[1], args[2], args[4], args[5])))
    ours_s, theirs_s = alternated(ours, theirs, warmup, rounds)
    return {"calls": len(rows) - warmup, "ours_us": 1e6 * ours_s, "mujoco_us": 1e6 * theirs_s,
            "ratio": rt.ratio(ours_s, theirs_s)}


def batch(poses, pairs: int, repeats: int, model) -> dict:
    """The batch of the first ``pairs`` poses: µs per pair of ``box_box`` at the usable cores
    and at one thread, of MuJoCo's ``mj_collision`` and ``mj_kinematics`` per pair over the
    whole blocks of ``model`` (an ``ExplicitPairs``), and the ratios."""
    from impactnet.models.box.exact import box_box

    args = poses.args(np.arange(min(pairs, len(poses))))
    n, cores = len(args[0]), usable_cores()
    blocks = model.blocks(args)
    timed = {"ours": [], "ours_one_thread": [], "kinematics": [], "collision": []}
    contacts = 0
    try:
        for repeat in range(repeats + 1):  # the first round warms up, not kept
            cores = kernel_threads(cores) or cores  # at most numba's pool
            ours = call_times([(box_box, args)], 0)[0]
            kernel_threads(1)
            one = call_times([(box_box, args)], 0)[0]
            kinematics, collision, contacts = model.pass_seconds(blocks) if blocks else (0, 0, 0)
            if repeat:
                for name, value in zip(timed, (ours, one, kinematics, collision)):
                    timed[name].append(value)
    finally:
        threads = kernel_threads()  # back to the default
    m = len(blocks) * model.pairs
    out = {"n": n, "threads": cores, "threads_default": threads, "repeats": repeats,
           "ours_us": 1e6 * statistics.median(timed["ours"]) / n,
           "ours_one_thread_us": 1e6 * statistics.median(timed["ours_one_thread"]) / n,
           "mujoco_pairs": m, "mujoco_us": None, "mujoco_kinematics_us": None,
           "mujoco_contacts_per_pair": contacts / m if m else None}
    if m:
        out["mujoco_us"] = 1e6 * statistics.median(timed["collision"]) / m
        out["mujoco_kinematics_us"] = 1e6 * statistics.median(timed["kinematics"]) / m
    out["ratio"] = rt.ratio(out["ours_us"], out["mujoco_us"])
    out["ratio_one_thread"] = rt.ratio(out["ours_one_thread_us"], out["mujoco_us"])
    return out


def measure(poses, plan, model, log=lambda message: None) -> dict:
    """N = 1 and the batch of one pose set (``plan``: a
    :class:`impactnet.training.bench.speed.section.SpeedPlan`)."""
    one = one_pair(poses, plan.single_calls, plan.single_warmup, plan.rounds)
    many = batch(poses, plan.pairs, plan.repeats, model)
    log(f"  speed {poses.name:<8} N=1 {one['ours_us']:.1f} us vs MuJoCo {one['mujoco_us']:.1f} "
        f"us | N={many['n']:,} {many['ours_us']:.3g} us/pair vs MuJoCo C "
        f"{many['mujoco_us'] or float('nan'):.3g} us/pair")
    return {"pose_set": poses.name, "description": poses.description, "one": one,
            "batch": many}


def tables(families: list[dict]) -> list[str]:
    """Markdown lines: the N = 1 table, the batch table and the goal lines."""
    lines = ["One pair per call, from Python (µs per call, median):", "",
             "| pose set | calls | box_box | MuJoCo from Python | box_box / MuJoCo "
             f"(goal <= {rt.GOAL_BOX_ONE:g}x) |", "|---|---:|---:|---:|---:|"]
    for f in families:
        one = f["one"]
        lines.append(f"| {f['pose_set']} | {one['calls']:,} | {rt.figure(one['ours_us'])} | "
                     f"{rt.figure(one['mujoco_us'])} | "
                     f"{rt.goal_cell(one['ratio'], rt.GOAL_BOX_ONE)} |")
    lines += ["", "A batch per call (µs per pair, median over repeats); MuJoCo: its C rate, "
              "`mj_collision` per pair over 1,000 explicit pairs (`mj_kinematics` beside it, "
              "not in the ratio):", "",
              "| pose set | N | threads | box_box | box_box, 1 thread | MuJoCo mj_collision | "
              "MuJoCo mj_kinematics | MuJoCo contacts / pair | box_box / MuJoCo "
              f"(goal <= {rt.GOAL_BOX_BATCH:g}x) | 1 thread / MuJoCo |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for f in families:
        b = f["batch"]
        cells = [rt.figure(b[k]) for k in ("ours_us", "ours_one_thread_us", "mujoco_us",
                                            "mujoco_kinematics_us", "mujoco_contacts_per_pair")]
        lines.append(f"| {f['pose_set']} | {b['n']:,} | {b['threads']} | " + " | ".join(cells)
                     + f" | {rt.goal_cell(b['ratio'], rt.GOAL_BOX_BATCH)} | "
                     f"{rt.times(b['ratio_one_thread'])} |")
    lines += [""]
    for f in families:
        lines.append("- " + rt.goal_line(f"{f['pose_set']}, N = 1", f["one"]["ours_us"],
                                         f["one"]["mujoco_us"], rt.GOAL_BOX_ONE))
        lines.append("- " + rt.goal_line(f"{f['pose_set']}, batch of {f['batch']['n']:,} on "
                                         f"{f['batch']['threads']} threads",
                                         f["batch"]["ours_us"], f["batch"]["mujoco_us"],
                                         rt.GOAL_BOX_BATCH))
    return lines
