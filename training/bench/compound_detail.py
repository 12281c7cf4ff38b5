"""Cost against detail: the compound oracle at each detail level next to FCL mesh-mesh, FCL
``Convex`` and MuJoCo, with their errors against the oracle (issue #20, step 5).

    impactnet bench compound [--quick] [--out docs/benchmarks] [--seed 1]

Levels: 40 ft on 40 ft stacking with solid castings (detail 1) and with the apertures' ring
pieces (detail 2), and a 40 ft spreader's twistlocks entering a detail-2 container's apertures
with heads of 8, 32, 128 and 256 sides. Poses: first contacts of the pair's family
(:mod:`impactnet.training.data.compound_poses`), pushed 0-2 mm. All figures of one level come
from the same poses in the same run; references are timed on their per-pose work only.
Writes ``compound.md`` (table) and ``compound_cost_vs_detail.png`` into ``--out``.
"""
from __future__ import annotations

import statistics
import time

import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.compound.summary import summarise
from impactnet.models.metrics import angle_deg
from impactnet.training.bench import compound_refs as refs
from impactnet.training.data.compound_data import pair_families
from impactnet.training.data.compound_poses import family_poses

#: (label, container detail, spreader sides or None, oracle poses, reference poses).
LEVELS = (("castings (detail 1)", 1, None, 5000, 40), ("apertures (detail 2)", 2, None, 600, 20),
          ("twistlocks, 8 sides", 2, 8, 600, 40), ("twistlocks, 32 sides", 2, 32, 400, 40),
          ("twistlocks, 128 sides", 2, 128, 200, 20), ("twistlocks, 256 sides", 2, 256, 100,
                                                        10))
#: The --quick run: poses divided by this.
QUICK_DIVISOR = 10
#: Pushes past the first contact (m).
PUSH_M = (0.0, 2e-3)
#: Issue #20's goal: the oracle at least this much faster than FCL mesh-mesh at detail 2.
GOAL_MESH_RATIO = 50.0


def level_poses(detail: int, sides, n: int, seed: int):
    """Bodies A, B and n first-contact poses of B (position (k, 3), quaternion (k, 4))."""
    container = cb.container("40ft", detail)
    body_b = container if sides is None else cb.spreader("40ft", sides=sides)
    family, (nominal, approach) = next(iter(pair_families(container, body_b).items()))
    position, quaternion, _ = family_poses(family, container, body_b, nominal, approach,
                                           PUSH_M, n, np.random.default_rng(seed))
    return container, body_b, position, quaternion


def _oracle(parts_a, parts_b, position, quaternion, singles: int):
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    batch = []
    for _ in range(2):
        start = time.perf_counter()
        found = compound_contacts(parts_a, np.zeros(3), identity, parts_b, position,
                                  quaternion)
        batch.append(time.perf_counter() - start)
    one = []
    for k in range(min(singles, len(position))):
        start = time.perf_counter()
        compound_contacts(parts_a, np.zeros(3), identity, parts_b, position[k], quaternion[k])
        one.append(time.perf_counter() - start)
    return min(batch) / len(position), statistics.median(one), found


def _pair_errors(found, theirs):
    """(share of poses with the same touching part pairs, p99 depth error (m), p99 normal
    angle (deg)) of a per-part-pair reference against the oracle."""
    same, depth, angle = 0, [], []
    for pose, pairs in enumerate(theirs):
        rows = found.of_pose(pose)
        mine = {(int(a), int(b)): r for a, b, r in zip(found.part_a[rows], found.part_b[rows],
                                                     range(rows.start, rows.stop))}
        same += set(mine) == set(pairs)
        for key in set(mine) & set(pairs):
            depth.append(abs(found.contacts.depth[mine[key]] - pairs[key][0]))
            angle.append(float(angle_deg(found.contacts.normal[mine[key]], pairs[key][1])))
    return same / max(len(theirs), 1), _p99(depth), _p99(angle)


def _p99(values) -> float:
    return float(np.percentile(values, 99)) if values else float("nan")


def _mesh_errors(summary, deepest):
    """(p99 depth error (m), p99 normal angle (deg)) of FCL mesh-mesh's deepest contact
    against the oracle's summary, on the poses where both touch."""
    depth, angle = [], []
    for pose, answer in enumerate(deepest):
        if answer is not None and summary.colliding[pose]:
            depth.append(abs(answer[0] - summary.depth[pose]))
            angle.append(float(angle_deg(answer[1], summary.normal[pose])))
    if not depth:
        return float("nan"), float("nan")
    return float(np.percentile(depth, 99)), float(np.percentile(angle, 99))


def measure_level(label, detail, sides, poses, ref_poses, seed) -> dict:
    """The figures of one level (module docstring)."""
    parts_a, parts_b, position, quaternion = level_poses(detail, sides, poses, seed)
    batch, one, found = _oracle(parts_a, parts_b, position, quaternion, 20)
    row = {"level": label, "poses": len(position), "oracle_us": 1e6 * batch,
           "oracle_one_us": 1e6 * one, "contacts_per_pose": len(found.pose) / len(position)}
    k = min(ref_poses, len(position))
    sub = found if k == len(position) else compound_contacts(
        parts_a, np.zeros(3), [1.0, 0, 0, 0], parts_b, position[:k], quaternion[:k])
    for name, fn in (("fcl_convex", refs.fcl_convex), ("mujoco", refs.mujoco_seconds)):
        seconds, theirs = fn(parts_a, parts_b, position[:k], quaternion[:k])
        row[f"{name}_us"] = 1e6 * seconds
        row[f"{name}_same_set"], row[f"{name}_depth_p99"], row[f"{name}_normal_p99"] = \
            _pair_errors(sub, theirs)
    seconds, deepest = refs.fcl_mesh(parts_a, parts_b, position[:k], quaternion[:k])
    row["fcl_mesh_us"] = 1e6 * seconds
    row["fcl_mesh_depth_p99"], row["fcl_mesh_normal_p99"] = _mesh_errors(summarise(sub),
                                                                         deepest)
    return row


def report(rows: list[dict], command: str) -> str:
    """The Markdown table of the levels, with the detail-2 goal against FCL mesh-mesh."""
    lines = ["# Compound oracle: cost against detail", "", f"Command: `{command}` (2 cores, "
             "one run; references timed on their per-pose work only, the oracle on a batch "
             "and at N = 1).", "",
             "| level | poses | part contacts / pose | oracle batch µs/pose | oracle N = 1 µs "
             "| FCL mesh-mesh µs | FCL Convex µs | MuJoCo µs |", "|---" * 8 + "|"]
    for r in rows:
        lines.append(f"| {r['level']} | {r['poses']} | {r['contacts_per_pose']:.1f} | "
                     f"{r['oracle_us']:.0f} | {r['oracle_one_us']:.0f} | {r['fcl_mesh_us']:.0f} "
                     f"| {r['fcl_convex_us']:.0f} | {r['mujoco_us']:.0f} |")
    lines += ["", "Errors against the oracle (p99 over the part pairs both find; FCL mesh-mesh: "
              "its deepest contact against the body-level summary):", "",
              "| level | FCL mesh depth / normal | FCL Convex same pairs, depth / normal "
              "| MuJoCo same pairs, depth / normal |", "|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['level']} | {1e3 * r['fcl_mesh_depth_p99']:.3g} mm / "
                     f"{r['fcl_mesh_normal_p99']:.1f}° | {100 * r['fcl_convex_same_set']:.0f} %, "
                     f"{1e3 * r['fcl_convex_depth_p99']:.3g} mm / "
                     f"{r['fcl_convex_normal_p99']:.2g}° "
                     f"| {100 * r['mujoco_same_set']:.0f} %, {1e3 * r['mujoco_depth_p99']:.3g} mm"
                     f" / {r['mujoco_normal_p99']:.2g}° |")
    detail2 = next((r for r in rows if "detail 2" in r["level"]), None)
    if detail2 is not None:
        ratio = detail2["fcl_mesh_us"] / detail2["oracle_us"]
        lines += ["", f"Goal (issue #20): the oracle >= {GOAL_MESH_RATIO:g}x faster than FCL "
                  f"mesh-mesh at detail 2: {ratio:.2f}x, "
                  f"{'met' if ratio >= GOAL_MESH_RATIO else 'NOT met'}."]
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path) -> None:
    """Cost per pose against the level, one line per method (log scale)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=120)
    x = np.arange(len(rows))
    for key, label in (("oracle_us", "oracle, batch"), ("oracle_one_us", "oracle, N = 1"),
                       ("fcl_mesh_us", "FCL mesh-mesh"), ("fcl_convex_us", "FCL Convex"),
                       ("mujoco_us", "MuJoCo")):
        ax.plot(x, [r[key] for r in rows], marker="o", label=label)
    ax.set(yscale="log", ylabel="µs per pose", title="Compound contact: cost against detail")
    ax.set_xticks(x, [r["level"] for r in rows], rotation=20, ha="right")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def run(quick: bool, out: str | None, seed: int, command: str) -> int:
    """Measure every level, print the table, and write it with the plot into ``out``."""
    from pathlib import Path

    divisor = QUICK_DIVISOR if quick else 1
    rows = []
    for label, detail, sides, poses, ref_poses in LEVELS:
        rows.append(measure_level(label, detail, sides, max(poses // divisor, 10),
                                  max(ref_poses // divisor, 5), seed))
        print(f"  {label}: oracle {rows[-1]['oracle_us']:.0f} us/pose", flush=True)
    text = report(rows, command)
    print(text)
    if out:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "compound.md").write_text(text, encoding="utf-8")
        plot(rows, folder / "compound_cost_vs_detail.png")
    return 0
