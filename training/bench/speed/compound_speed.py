"""``compound_answer`` against MuJoCo 4 called from Python, per level of ``impactnet bench
compound`` (:mod:`impactnet.training.bench.compound.detail`).

* N = 1: ``compound_answer`` on one pose per call (A at the origin, B's pose; both passed, the
  answer's arrays out), against MuJoCo's one pose from Python
  (:func:`impactnet.training.bench.speed.mujoco_calls.compound_call`: the model of the same
  geoms, one per part, meshes for convex parts, ``multiccd`` off; qpos of both bodies in,
  ``mj_kinematics``, ``mj_collision``, the contacts' pos, frame, dist and geom out as arrays),
  on the same poses, in alternating slices; medians.
* Batch: ``compound_answer`` per pose over the level's batch (timed by the caller, the kernels'
  threads at the usable cores), against the same MuJoCo per pose.

Ratios are ours / MuJoCo, time per pose (:mod:`impactnet.training.bench.speed.ratios`).
"""
from __future__ import annotations

import numpy as np

from impactnet.training.bench.speed import ratios as rt
from impactnet.training.bench.timing import alternated, median_per_call

ORIGIN, IDENTITY = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
#: Alternating slices of the N = 1 timing.
ROUNDS = 3
#: Columns of the speed table: (key, title) of the per-level figures (µs) and ratios.
COLUMNS = (("oracle_one_us", "compound_answer N = 1"),
           ("oracle_us", "compound_answer batch, per pose"),
           ("mujoco_py_us", "MuJoCo from Python, per pose"))


def one_pose(parts_a, parts_b, position, quaternion, calls: int, batch_us: float) -> dict:
    """``oracle_one_us`` (compound_answer, N = 1), ``mujoco_py_us`` (MuJoCo's one pose from
    Python) on the first ``calls`` poses, and the ratios ``one_vs_mujoco`` and
    ``batch_vs_mujoco`` (``batch_us``: the caller's batch per pose); without MuJoCo,
    ``mujoco_py_missing`` says why and only the first is measured."""
    from impactnet.models.compound import compound_answer

    k = min(calls, len(position))
    warmup = min(3, k // 4)
    ours = [(compound_answer, (parts_a, ORIGIN, IDENTITY, parts_b, position[r], quaternion[r]))
            for r in range(k)]
    try:
        from impactnet.training.bench.speed.mujoco_calls import compound_call

        call = compound_call(parts_a, parts_b)
    except ImportError as exc:
        return {"oracle_one_us": 1e6 * median_per_call(compound_answer, [a for _, a in ours],
                                                        warmup)[0],
                "mujoco_py_missing": str(exc)}
    theirs = [(call, (ORIGIN, IDENTITY, position[r], quaternion[r])) for r in range(k)]
    ours_s, theirs_s = alternated(ours, theirs, warmup, ROUNDS)
    out = {"oracle_one_us": 1e6 * ours_s, "mujoco_py_us": 1e6 * theirs_s, "timed_poses": k - warmup}
    out["one_vs_mujoco"] = rt.ratio(out["oracle_one_us"], out["mujoco_py_us"])
    out["batch_vs_mujoco"] = rt.ratio(batch_us, out["mujoco_py_us"])
    return out


def table(rows: list[dict]) -> list[str]:
    """Markdown lines: per level the three times and the two ratios against their goals."""
    lines = ["| level | " + " | ".join(title for _, title in COLUMNS)
             + f" | N = 1 / MuJoCo (goal <= {rt.GOAL_COMPOUND_ONE:g}x) "
             f"| batch / MuJoCo (goal <= {rt.GOAL_COMPOUND_BATCH:g}x) |",
             "|---" + "|---:" * 5 + "|"]
    for r in rows:
        cells = [rt.figure(r[key]) if r.get(key) is not None else "not measured"
                 for key, _ in COLUMNS]
        lines.append(f"| {r['level']} | " + " | ".join(cells)
                     + f" | {rt.goal_cell(r.get('one_vs_mujoco'), rt.GOAL_COMPOUND_ONE)} | "
                     f"{rt.goal_cell(r.get('batch_vs_mujoco'), rt.GOAL_COMPOUND_BATCH)} |")
    return lines


def goal_lines(rows: list[dict]) -> list[str]:
    """One line per level and goal: met, NOT met, or not measured."""
    out = []
    for r in rows:
        out.append("- " + rt.goal_line(f"{r['level']}, N = 1", r.get("oracle_one_us"),
                                       r.get("mujoco_py_us"), rt.GOAL_COMPOUND_ONE))
        out.append("- " + rt.goal_line(f"{r['level']}, batch of {r['poses']:,} per pose",
                                       r.get("oracle_us"), r.get("mujoco_py_us"),
                                       rt.GOAL_COMPOUND_BATCH))
    return out
