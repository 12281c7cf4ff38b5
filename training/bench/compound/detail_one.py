"""Speed of the compound oracle on container stacking, next to python-fcl on the same parts.

    python -m impactnet.training.bench.compound.detail_one [--poses 100000] [--quick]

Poses: a 40 ft container with its castings set down on another (offset up to 50 mm, tilted up
to 2 mrad about a random axis, pushed 0-5 mm), seeded. Measured in one run, one thread:

* the oracle (:func:`impactnet.models.compound.oracle.compound_contacts`) on all poses in one
  call (median of repeats), and at N = 1 (median over single calls);
* python-fcl's Box-Box on the same part boxes, every part pair of a pose collided in a Python
  loop (what an engine without a broadphase does; 81 pairs for two containers), on a subset.

The issue's goals (#20): <= 15 us per pose at N = 1e5, <= 150 us at N = 1, >= 5x FCL on the
same part boxes. Reported as measured, met or not. ``impactnet bench compound``
(:mod:`impactnet.training.bench.compound.detail`) runs this first and puts these lines on top
of its report.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.geometry.rotations import quaternion_to_matrix

GOAL_BATCH_US, GOAL_ONE_US, GOAL_FCL_RATIO = 15.0, 150.0, 5.0


def stacking_poses(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """B's positions (n, 3) and quaternions (n, 4) on A (40 ft on 40 ft, A at the origin)."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0.0, 2e-3, n)
    quaternion = np.c_[np.cos(angle / 2), np.sin(angle / 2)[:, None] * axis]
    height = cb.CONTAINERS["40ft"][2]
    position = np.c_[rng.uniform(-0.05, 0.05, (n, 2)), height - rng.uniform(0, 5e-3, n)]
    return position, quaternion


def fcl_seconds_per_pose(parts, position, quaternion) -> float:
    """Median seconds per pose of FCL Box-Box over every part pair (a Python loop)."""
    import fcl

    request = fcl.CollisionRequest(num_max_contacts=8, enable_contact=True)
    a = [fcl.CollisionObject(fcl.Box(*p.size), fcl.Transform(np.array(p.centre, float)))
         for p in parts]
    b = [fcl.CollisionObject(fcl.Box(*p.size)) for p in parts]
    centres = np.array([p.centre for p in parts], float)
    # B's part centres in the world for every pose, vectorised before timing: FCL's time is
    # its own (set the transforms, collide), not NumPy's per-pose overhead
    world = position[:, None, :] + np.einsum("nij,pj->npi", quaternion_to_matrix(quaternion),
                                             centres)
    times = []
    for q, placed in zip(quaternion, world):
        start = time.perf_counter()
        for obj, centre in zip(b, placed):
            obj.setTransform(fcl.Transform(q, centre))
        for obj_a in a:
            for obj_b in b:
                fcl.collide(obj_a, obj_b, request, fcl.CollisionResult())
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def measure(poses: int, repeats: int, singles: int, fcl_poses: int) -> dict:
    """Seconds per pose of the oracle (batch, N = 1) and of the FCL loop, same run."""
    parts = cb.container("40ft")
    position, quaternion = stacking_poses(poses)
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    compound_contacts(parts, np.zeros(3), identity, parts, position[:100], quaternion[:100])
    batch = []
    for _ in range(repeats):
        start = time.perf_counter()
        found = compound_contacts(parts, np.zeros(3), identity, parts, position, quaternion)
        batch.append(time.perf_counter() - start)
    one = []
    for k in range(singles):
        start = time.perf_counter()
        compound_contacts(parts, np.zeros(3), identity, parts, position[k], quaternion[k])
        one.append(time.perf_counter() - start)
    out = {"poses": poses, "contacts_per_pose": len(found.pose) / poses,
           "batch_us_per_pose": 1e6 * statistics.median(batch) / poses,
           "one_us": 1e6 * statistics.median(one[min(20, singles // 5):])}
    try:
        out["fcl_us_per_pose"] = 1e6 * fcl_seconds_per_pose(parts, position[:fcl_poses],
                                                            quaternion[:fcl_poses])
    except ImportError:
        out["fcl_us_per_pose"] = None
    return out


def report(figures: dict) -> str:
    """Markdown lines: the figures and each goal, met or not."""
    batch, one, fcl = (figures["batch_us_per_pose"], figures["one_us"],
                       figures["fcl_us_per_pose"])
    lines = [f"40 ft on 40 ft stacking, {figures['poses']:,} poses, "
             f"{figures['contacts_per_pose']:.2f} part contacts per pose:", "",
             f"- oracle, batch: {batch:.1f} us/pose (goal <= {GOAL_BATCH_US:g}): "
             f"{'met' if batch <= GOAL_BATCH_US else 'NOT met'}",
             f"- oracle, N = 1: {one:.0f} us (goal <= {GOAL_ONE_US:g}): "
             f"{'met' if one <= GOAL_ONE_US else 'NOT met'}"]
    if fcl is not None:
        ratio = fcl / batch
        lines.append(f"- FCL Box-Box over all 81 part pairs, Python loop: {fcl:.0f} us/pose; "
                     f"oracle batch {ratio:.1f}x faster (goal >= {GOAL_FCL_RATIO:g}x): "
                     f"{'met' if ratio >= GOAL_FCL_RATIO else 'NOT met'}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.training.bench.compound.detail_one",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--poses", type=int, default=100_000, help="poses of the batch")
    parser.add_argument("--quick", action="store_true", help="a smoke run (seconds)")
    args = parser.parse_args(argv)
    if args.quick:
        figures = measure(min(args.poses, 2000), 2, 30, 20)
    else:
        figures = measure(args.poses, 3, 300, 300)
    print(report(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
