"""Cost against detail: the compound oracle at each detail level next to FCL mesh-mesh, FCL
``Convex`` and MuJoCo, with their errors against the oracle (issue #20, step 5).

    impactnet bench compound [--quick] [--out docs/benchmarks]
                             [--plot docs/images/compound_cost_vs_detail.png] [--seed 1]

Levels (:data:`LEVELS`): 40 ft on 40 ft stacking with solid castings (detail 1) and with the
top castings' apertures as ring pieces (detail 2), and a 40 ft spreader's twistlocks entering
a detail-2 container's apertures with heads of 8, 32, 128 and 256 sides. Poses: first contacts
of the pair's family (:mod:`impactnet.training.data.compound_poses`: stacking with offsets up to
5 cm, yaw up to 2 mrad, tilt up to 10 mrad; twistlock entry with the heads within 15 mm along
and 6 mm across of the apertures' centres, yaw up to 5 mrad, tilt up to 10 mrad), lowered until
they touch and pushed 0-2 mm on, seeded. All figures of a level come from the same poses in one
run (the references on the first poses of the oracle's batch); the oracle is timed on the
whole batch (best of :data:`BATCH_REPEATS`) and at N = 1 (median of single calls); the
references per pose (:mod:`impactnet.training.bench.compound_refs`). Each reference's errors:
the share of poses where it touches the oracle's set of part pairs, the share of poses within
the MuJoCo-agreement tolerances of issue #20 (the same set; normals within 1 deg, depths within
1e-6 m), and the depth and normal errors over the part pairs both find. The detail-1 goals come
from :mod:`impactnet.training.bench.compound` in the same run.
"""
from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.metrics import angle_deg
from impactnet.training.bench import compound as detail_one
from impactnet.training.bench.compound_refs import REFERENCES
from impactnet.training.data.compound_data import pair_families
from impactnet.training.data.compound_poses import family_poses

#: (label, container detail, spreader sides or None, oracle batch poses, reference poses).
LEVELS = (("castings (detail 1)", 1, None, 5000, 300),
          ("apertures (detail 2)", 2, None, 1000, 200),
          ("twistlocks, 8 sides", 2, 8, 600, 200),
          ("twistlocks, 32 sides", 2, 32, 400, 200),
          ("twistlocks, 128 sides", 2, 128, 200, 100),
          ("twistlocks, 256 sides", 2, 256, 100, 100))
#: The --quick run: poses divided by this (at least :data:`QUICK_MIN` per level).
QUICK_DIVISOR, QUICK_MIN = 10, 10
#: Pushes past the first contact (m).
PUSH_M = (0.0, 2e-3)
#: Oracle batch timings (the best is kept) and single calls at N = 1 (the median is kept).
BATCH_REPEATS, SINGLES = 2, 50
#: Issue #20's agreement tolerances of a part pair (deg, m).
NORMAL_TOL_DEG, DEPTH_TOL_M = 1.0, 1e-6
#: Detail-1 goal run (poses, batch repeats, N = 1 calls, FCL Box-Box poses), full and quick.
DETAIL_ONE = {False: (100_000, 3, 300, 300), True: (2000, 2, 30, 20)}


def level_poses(detail: int, sides, n: int, seed: int):
    """Bodies A, B and up to n first-contact poses of B: position (k, 3) m, quaternion (k, 4)."""
    container = cb.container("40ft", detail)
    body_b = container if sides is None else cb.spreader("40ft", sides=sides)
    family, (nominal, approach) = next(iter(pair_families(container, body_b).items()))
    position, quaternion, _ = family_poses(family, container, body_b, nominal, approach,
                                           PUSH_M, n, np.random.default_rng(seed))
    return container, body_b, position, quaternion


def time_oracle(parts_a, parts_b, position, quaternion, singles: int):
    """(seconds per pose of the batch, seconds of one call at N = 1, the batch's answer)."""
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    compound_contacts(parts_a, np.zeros(3), identity, parts_b, position[0], quaternion[0])
    batch = []
    for _ in range(BATCH_REPEATS):
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


def pair_errors(found, theirs: list[dict]) -> dict:
    """A reference's errors against the oracle's answer ``found`` on its first poses.

    Returns
    -------
    dict
        ``same_set`` and ``rows_ok``: shares of poses (module docstring); ``pairs``: part
        pairs both find; ``depth_p99``, ``depth_max`` (m) and ``normal_p99``, ``normal_max``
        (deg) over those pairs (NaN where there are none).
    """
    same = ok = 0
    depth, angle = [], []
    for pose, pairs in enumerate(theirs):
        rows = found.of_pose(pose)
        mine = {(int(a), int(b)): r for a, b, r in zip(found.part_a[rows], found.part_b[rows],
                                                     range(rows.start, rows.stop))}
        good = set(mine) == set(pairs)
        same += good
        for key in set(mine) & set(pairs):
            depth.append(abs(found.contacts.depth[mine[key]] - pairs[key][0]))
            angle.append(float(angle_deg(found.contacts.normal[mine[key]], pairs[key][1])))
            good &= depth[-1] <= DEPTH_TOL_M and angle[-1] <= NORMAL_TOL_DEG
        ok += good
    n = max(len(theirs), 1)
    return {"same_set": same / n, "rows_ok": ok / n, "pairs": len(depth),
            "depth_p99": _stat(depth, 99), "depth_max": _stat(depth, 100),
            "normal_p99": _stat(angle, 99), "normal_max": _stat(angle, 100)}


def _stat(values: list, q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def measure_level(label, detail, sides, poses, ref_poses, seed) -> dict:
    """The figures of one level: ``poses`` (the batch's N), ``ref_poses``, ``oracle_us``
    (batch, µs per pose), ``oracle_one_us`` (N = 1), ``contacts_per_pose`` and per reference
    ``<key>_us`` (µs per pose) and ``<key>_errors`` (:func:`pair_errors`)."""
    parts_a, parts_b, position, quaternion = level_poses(detail, sides, poses, seed)
    batch, one, found = time_oracle(parts_a, parts_b, position, quaternion, SINGLES)
    k = min(ref_poses, len(position))
    row = {"level": label, "poses": len(position), "ref_poses": k, "oracle_us": 1e6 * batch,
           "oracle_one_us": 1e6 * one, "contacts_per_pose": len(found.pose) / len(position)}
    for key, _, reference in REFERENCES:
        try:
            seconds, theirs = reference(parts_a, parts_b, position[:k], quaternion[:k])
        except ImportError as exc:  # the dev extra (python-fcl, mujoco) is not installed
            row[f"{key}_missing"] = str(exc)
            continue
        row[f"{key}_us"] = 1e6 * seconds
        row[f"{key}_errors"] = pair_errors(found, theirs)
    return row


def run(quick: bool, out: str | None, seed: int, command: str, plot_path: str | None = None,
        log=print) -> int:
    """Measure the detail-1 goals and every level, print the report, and write it (``out``
    /compound.md) with the plot (``plot_path``, default ``out``/compound_cost_vs_detail.png)."""
    from impactnet.training.bench.compound_report import plot, report

    divisor = QUICK_DIVISOR if quick else 1
    started = time.perf_counter()
    goals = detail_one.measure(*DETAIL_ONE[quick])
    log(f"  detail-1 goals: {goals['poses']:,} poses, {goals['batch_us_per_pose']:.1f} us/pose")
    rows = []
    for label, detail, sides, poses, ref_poses in LEVELS:
        rows.append(measure_level(label, detail, sides, max(poses // divisor, QUICK_MIN),
                                  max(ref_poses // divisor, QUICK_MIN), seed))
        log(f"  {label}: oracle {rows[-1]['oracle_us']:.0f} us/pose "
            f"({time.perf_counter() - started:.0f} s)")
    text = report(rows, goals, command, time.perf_counter() - started)
    log(text)
    if out:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "compound.md").write_text(text, encoding="utf-8")
    if out or plot_path:
        path = Path(plot_path) if plot_path else Path(out) / "compound_cost_vs_detail.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        plot(rows, path)
    return 0
