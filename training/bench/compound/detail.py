"""Cost against detail: the compound oracle at each detail level next to FCL mesh-mesh, FCL
``Convex`` and MuJoCo, with their errors against the oracle (issue #20, step 5).

    impactnet bench compound [--quick] [--out docs/benchmarks]
                             [--plot docs/images/compound_cost_vs_detail.png] [--seed 1]

Levels (:data:`LEVELS`): 40 ft on 40 ft stacking with solid castings (detail 1) and with the
top castings' apertures as ring pieces (detail 2), a 40 ft spreader's twistlocks entering
a detail-2 container's apertures with heads of 8, 32, 128 and 256 sides, and a detail-2 40 ft
container sliding along a cell guide (its angle and chamfered entry). Poses: first contacts
of the pair's family (:mod:`impactnet.training.data.compound_poses`: stacking with offsets up to
5 cm, yaw up to 2 mrad, tilt up to 10 mrad; twistlock entry with the heads within 15 mm along
and 6 mm across of the apertures' centres, yaw up to 5 mrad, tilt up to 10 mrad; guide sliding
at a random height, yaw up to 10 mrad, tilt up to 5 mrad), lowered (pushed) until they touch
and pushed 0-2 mm on, seeded. All figures of a level come from the same poses in one run (the
references on the first poses of the oracle's batch). The oracle is the public
``compound_answer`` (part contacts and summary): timed on the whole batch (median of
:data:`BATCH_REPEATS`, the kernels' threads at the usable cores) and at N = 1 (median of single
calls), the latter alternated with MuJoCo called from Python on the same poses
(:mod:`impactnet.training.bench.speed.compound_speed`: issue #32's goals, N = 1 at most 2x and
the batch per pose at most 1x MuJoCo's one pose from Python); the references per pose
(:mod:`impactnet.training.bench.compound.references`). Each reference's errors:
the share of poses where it touches the oracle's set of part pairs, the share of poses within
the MuJoCo-agreement tolerances of issue #20 (the same set; normals within 1 deg, depths within
1e-6 m), and the depth and normal errors over the part pairs both find. The detail-1 goals come
from :mod:`impactnet.training.bench.compound.detail_one` in the same run.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from impactnet.models.compound import compound_answer
from impactnet.models.compound import crane_bodies as cb
from impactnet.models.metrics import angle_deg
from impactnet.training.bench.compound import detail_one
from impactnet.training.bench.compound.references import REFERENCES
from impactnet.training.bench.speed.box_pairs import kernel_threads, usable_cores, warm_kernels
from impactnet.training.bench.speed.compound_speed import IDENTITY, ORIGIN, one_pose
from impactnet.training.bench.timing import median_repeated
from impactnet.training.data.compound_data import pair_families
from impactnet.training.data.compound_poses import family_poses

#: Body B of a level whose body A is a cell guide (B: a container of the level's detail).
GUIDE = "cell guide"
#: (label, container detail, body B: None (a container on a container), a spreader's head
#: sides, or :data:`GUIDE`, oracle batch poses, reference poses).
LEVELS = (("castings (detail 1)", 1, None, 5000, 300),
          ("apertures (detail 2)", 2, None, 1000, 200),
          ("twistlocks, 8 sides", 2, 8, 600, 200),
          ("twistlocks, 32 sides", 2, 32, 400, 200),
          ("twistlocks, 128 sides", 2, 128, 200, 100),
          ("twistlocks, 256 sides", 2, 256, 100, 100),
          ("cell guide", 2, GUIDE, 1000, 200))
#: The --quick run: poses divided by this (at least :data:`QUICK_MIN` per level).
QUICK_DIVISOR, QUICK_MIN = 10, 10
#: Pushes past the first contact (m).
PUSH_M = (0.0, 2e-3)
#: Oracle batch timings and single calls at N = 1 (medians are kept).
BATCH_REPEATS, SINGLES = 3, 50
#: Issue #20's agreement tolerances of a part pair (deg, m).
NORMAL_TOL_DEG, DEPTH_TOL_M = 1.0, 1e-6
#: Detail-1 goal run (poses, batch repeats, N = 1 calls, FCL Box-Box poses), full and quick.
DETAIL_ONE = {False: (100_000, 3, 300, 300), True: (2000, 2, 30, 20)}


def bodies(detail: int, body_b) -> tuple[tuple, tuple]:
    """Parts of A and B of a level (``body_b`` as in :data:`LEVELS`)."""
    container = cb.container("40ft", detail)
    if body_b == GUIDE:
        return cb.cell_guide(), container
    return container, container if body_b is None else cb.spreader("40ft", sides=body_b)


def level_poses(detail: int, body_b, n: int, seed: int):
    """Bodies A, B and up to n first-contact poses of B: position (k, 3) m, quaternion (k, 4)."""
    parts_a, parts_b = bodies(detail, body_b)
    family, (nominal, approach) = next(iter(pair_families(parts_a, parts_b).items()))
    position, quaternion, _ = family_poses(family, parts_a, parts_b, nominal, approach,
                                           PUSH_M, n, np.random.default_rng(seed))
    return parts_a, parts_b, position, quaternion


def time_batch(parts_a, parts_b, position, quaternion):
    """(seconds per pose of ``compound_answer`` on the whole batch, median of
    :data:`BATCH_REPEATS` after a warm-up call, on the usable cores; the batch's answer; the
    cores)."""
    cores = usable_cores()
    kernel_threads(cores)
    try:
        answer = compound_answer(parts_a, ORIGIN, IDENTITY, parts_b, position, quaternion)
        seconds = median_repeated(lambda: compound_answer(parts_a, ORIGIN, IDENTITY, parts_b,
                                                          position, quaternion),
                                  BATCH_REPEATS, warmup=False)
    finally:
        kernel_threads()
    return seconds / len(position), answer, cores


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


def measure_level(label, detail, body_b, poses, ref_poses, seed) -> dict:
    """The figures of one level: ``poses`` (the batch's N), ``ref_poses``, ``oracle_us``
    (``compound_answer`` batch, µs per pose, on ``threads``), ``contacts_per_pose``, the N = 1 and
    MuJoCo-from-Python figures of :func:`~impactnet.training.bench.speed.compound_speed.one_pose`
    (``oracle_one_us`` among them) and per reference ``<key>_us`` (µs per pose) and ``<key>_errors``
    (:func:`pair_errors`)."""
    parts_a, parts_b, position, quaternion = level_poses(detail, body_b, poses, seed)
    batch, answer, threads = time_batch(parts_a, parts_b, position, quaternion)
    found = answer.parts
    k = min(ref_poses, len(position))
    row = {"level": label, "poses": len(position), "ref_poses": k, "oracle_us": 1e6 * batch,
           "threads": threads, "contacts_per_pose": len(found.pose) / len(position)}
    row |= one_pose(parts_a, parts_b, position, quaternion, SINGLES, row["oracle_us"])
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
    from impactnet.training.bench.compound.report import plot, report

    divisor = QUICK_DIVISOR if quick else 1
    started = time.perf_counter()
    warm_kernels(log)
    goals = detail_one.measure(*DETAIL_ONE[quick])
    log(f"  detail-1 goals: {goals['poses']:,} poses, {goals['batch_us_per_pose']:.1f} us/pose")
    rows = []
    for label, detail, body_b, poses, ref_poses in LEVELS:
        rows.append(measure_level(label, detail, body_b, max(poses // divisor, QUICK_MIN),
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
