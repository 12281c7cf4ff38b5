"""Timings of the gap query (issue #34, item 3) next to python-fcl's ``distance`` and MuJoCo's
``mj_geomDistance``, each called from Python on the same poses in the same run, and next to the
compiled exact alternative (brute_force.py), which chose GJK.

Run from the repository root: ``.venv/bin/python -m tests.models.distance.bench_gap``
(``--rows`` the batch, ``--single`` the poses timed one query at a time, ``--repeats``).

Pairs: a 20 ft container under a spreader's frame (box-box), and a corner casting under a
twistlock head of 32 or 128 sides (box-frustum), at random orientations and gaps of 0-1 m
(scenarios.py). One kernel thread. Per query: the best of ``--repeats`` loops, in us:

* ``ours N=1``: :func:`~impactnet.models.distance.query.polytope_gaps` with one pose (the
  entry's checks, its cache of hull tables, one row of the serial kernel);
* ``ours batch``: one :meth:`~impactnet.models.distance.query.PolytopePair.gaps` call over the
  batch (the parallel kernel on one thread), per row;
* ``brute batch``: the exact alternative's row loop (distance only), per row;
* ``fcl``: two ``setTransform`` and ``fcl.distance`` with nearest points;
* ``mujoco``: the two geoms' frames written (precomputed by ``mj_kinematics``) and
  ``mj_geomDistance`` with its segment.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from impactnet.models import compiled
from impactnet.models.compound.crane_bodies import (
    CASTING,
    CONTAINERS,
    SPREADER_FRAME_HEIGHT_ASSUMED,
    TWISTLOCK_HEAD_ASSUMED,
    TWISTLOCK_HEIGHT_ASSUMED,
)
from impactnet.models.compound.hull import convex_hull
from impactnet.models.compound.shapes import frustum_points
from impactnet.models.distance.query import PolytopePair, polytope_gaps
from tests.models.distance.brute_force import brute_gaps, brute_tables
from tests.models.distance.others import (
    MUJOCO_DISTMAX,
    fcl_geometry,
    mujoco_model,
    mujoco_quaternions,
)
from tests.models.distance.scenarios import at_gaps, box_corners, gaps

#: The timed pairs: (A's vertices, B's vertices).
PAIRS = {
    "box-box": (box_corners(CONTAINERS["20ft"]),
                box_corners((*CONTAINERS["20ft"][:2], SPREADER_FRAME_HEIGHT_ASSUMED))),
    "box-frustum32": (box_corners(CASTING),
                      frustum_points(TWISTLOCK_HEAD_ASSUMED, 32, -TWISTLOCK_HEIGHT_ASSUMED, 0.5)),
    "box-frustum128": (box_corners(CASTING),
                       frustum_points(TWISTLOCK_HEAD_ASSUMED, 128, -TWISTLOCK_HEIGHT_ASSUMED,
                                      0.5)),
}


def _best(run, repeats: int, count: int) -> float:
    """The best of ``repeats`` runs of ``run()``, in us per one of its ``count`` queries."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return 1e6 * best / count


def _fcl(case, single: int):
    import fcl

    a = fcl.CollisionObject(fcl_geometry(case.vertices_a), fcl.Transform())
    b = fcl.CollisionObject(fcl_geometry(case.vertices_b), fcl.Transform())
    transforms = [(fcl.Transform(case.rotation_a[i], case.position_a[i]),
                   fcl.Transform(case.rotation_b[i], case.position_b[i])) for i in range(single)]
    request = fcl.DistanceRequest(enable_nearest_points=True)

    def run():
        for ta, tb in transforms:
            a.setTransform(ta)
            b.setTransform(tb)
            fcl.distance(a, b, request, fcl.DistanceResult())
    return run


def _mujoco(case, single: int):
    import mujoco

    model, data = mujoco_model(case.vertices_a, case.vertices_b)
    qa, qb = mujoco_quaternions(case.rotation_a), mujoco_quaternions(case.rotation_b)
    frames = []
    for i in range(single):
        data.qpos[:] = np.r_[case.position_a[i], qa[i], case.position_b[i], qb[i]]
        mujoco.mj_kinematics(model, data)
        frames.append((data.geom_xpos.copy(), data.geom_xmat.copy()))
    fromto = np.zeros(6)

    def run():
        for xpos, xmat in frames:
            data.geom_xpos[:] = xpos
            data.geom_xmat[:] = xmat
            mujoco.mj_geomDistance(model, data, 0, 1, MUJOCO_DISTMAX, fromto)
    return run


def _brute(case, rows: int):
    ra, pa = case.rotation_a[:rows], case.position_a[:rows]
    t = np.einsum("pji,pj->pi", ra, case.position_b[:rows] - pa)
    r = np.ascontiguousarray(np.einsum("pji,pjk->pik", ra, case.rotation_b[:rows]))
    fa, fb = brute_tables(convex_hull(case.vertices_a)), brute_tables(convex_hull(case.vertices_b))
    out = np.empty(rows)
    brute_gaps(fa, fb, t[:1], r[:1], out)  # compile
    return lambda: brute_gaps(fa, fb, t, r, out)


def measure(name: str, rows: int, single: int, repeats: int) -> dict:
    """The timings of one pair (module docstring), us per query."""
    va, vb = PAIRS[name]
    case = at_gaps(va, vb, gaps(np.random.default_rng(34), rows), np.random.default_rng(3))
    pair = PolytopePair(va, vb)
    pose = (case.position_a, case.rotation_a, case.position_b, case.rotation_b)
    polytope_gaps(va, vb, *(x[0] for x in pose))  # compile / load, both kernels
    pair.gaps(*(x[:compiled.PARALLEL_MIN_ROWS] for x in pose))

    def one_at_a_time():
        for i in range(single):
            polytope_gaps(va, vb, pose[0][i], pose[1][i], pose[2][i], pose[3][i])

    brute_rows = min(rows, 20_000 if name == "box-box" else 2_000)
    return {
        "ours N=1": _best(one_at_a_time, repeats, single),
        "ours batch": _best(lambda: pair.gaps(*pose), repeats, rows),
        "brute batch": _best(_brute(case, brute_rows), repeats, brute_rows),
        "fcl": _best(_fcl(case, single), repeats, single),
        "mujoco": _best(_mujoco(case, single), repeats, single),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=100_000)
    parser.add_argument("--single", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    compiled.set_threads(1)
    columns = ("ours N=1", "ours batch", "brute batch", "fcl", "mujoco")
    print(f"us per query, one thread; batch {args.rows} rows, N=1 over {args.single} poses")
    print(f"{'pair':<16}" + "".join(f"{c:>13}" for c in columns))
    for name in PAIRS:
        found = measure(name, args.rows, args.single, args.repeats)
        print(f"{name:<16}" + "".join(f"{found[c]:>13.3f}" for c in columns))


if __name__ == "__main__":
    main()
