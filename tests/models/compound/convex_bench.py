"""The convex solver's cost (not a test module): ``python -m tests.models.compound.convex_bench``.

One thread (the kernel threads set to 1), medians of repeated runs:

* per pair of hulls, a twistlock head of 8, 32, 128 and 256 sides (a stadium frustum) on a
  0.3 m plate and on another head, seeded random poses near contact
  (:func:`tests.models.compound.convex_cases.random_poses`): a batch of 256 pairs in one call
  (per pair) and one pair per call;
* the whole :func:`impactnet.models.compound.compound_answer` of a 40 ft spreader on a detail-2
  40 ft container with 32 and 128 sides, on the golden set's recorded poses
  (``tests/data/golden/compound_twistlocks_*.npz``): one pose per call, and all in one call
  (per pose).

Only public entries are timed, so the same module times an older solver where that one is on
the path instead.

``--scan``: the choice of ``SCAN_PAIRS`` (:mod:`impactnet.models.compound.sat_walk`): per row
of two small hulls (a box, an aperture's ring pieces, 8- to 32-sided heads; seeded resting
poses, 1 mm tilt), the whole contact with every row forced to walk the Gauss-map trees and
forced to test every edge pair.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

BATCH, SINGLES, REPEATS = 256, 24, 5
GOLDEN = Path(__file__).resolve().parents[2] / "data" / "golden"


def _median_time(call, repeats: int = REPEATS) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def pair_costs() -> list[dict]:
    """Seconds per pair of hulls, batch and single, for each head and partner."""
    from impactnet.models.compound.convex_contact import convex_contacts
    from impactnet.models.compound.hull import box_hull
    from tests.models.compound.convex_cases import PLATE, head, random_poses

    rows = []
    for sides in (8, 32, 128, 256):
        b = head(sides)
        for partner, a in (("plate", box_hull(PLATE)), ("head", head(sides))):
            pa, ra, pb, rb = random_poses(a, b, BATCH, sides)
            convex_contacts(a, b, pa, ra, pb, rb)  # compiled or loaded
            batch = _median_time(lambda: convex_contacts(a, b, pa, ra, pb, rb)) / BATCH
            single = float(np.median([_median_time(lambda k=k: convex_contacts(
                a, b, pa[k:k + 1], ra[k:k + 1], pb[k:k + 1], rb[k:k + 1]))
                for k in range(SINGLES)]))
            rows.append({"sides": sides, "on": partner, "batch_s": batch, "single_s": single})
    return rows


def answer_costs() -> list[dict]:
    """Seconds per pose of compound_answer, one pose per call and all poses in one call."""
    from impactnet.models.compound import compound_answer, container, spreader

    rows = []
    for sides in (32, 128):
        data = np.load(GOLDEN / f"compound_twistlocks_{sides}.npz")
        parts_a, parts_b = container("40ft", detail=2), spreader("40ft", sides=sides)
        pa, qa, pb, qb = (data[k] for k in ("position_a", "quaternion_a", "position_b",
                                              "quaternion_b"))
        n = len(pa)
        compound_answer(parts_a, pa, qa, parts_b, pb, qb)
        whole = _median_time(lambda: compound_answer(parts_a, pa, qa, parts_b, pb, qb), 3) / n
        picked = range(0, n, max(1, n // 40))
        single = float(np.median([_median_time(lambda k=k: compound_answer(
            parts_a, pa[k], qa[k], parts_b, pb[k], qb[k]), 3) for k in picked]))
        rows.append({"sides": sides, "poses": n, "batch_s": whole, "single_s": single})
    return rows


def scan_costs() -> list[dict]:
    """Seconds per row of the contact rows, the edge search forced to walk, then to scan."""
    from impactnet.models.compound import convex_contact as cc
    from impactnet.models.compound import crane_bodies as cb
    from impactnet.models.compound.hull import box_hull, hull_of
    from impactnet.models.compound.hull_stack import stack_hulls
    from tests.models.compound.convex_cases import head, resting_poses

    rings = [hull_of(p) for p in cb.container("40ft", detail=2) if "/ring_" in p.name]
    hulls = {"box": box_hull((0.2, 0.15, 0.1)), "ring12": min(rings, key=lambda h: len(h.edges)),
             "ring18": max(rings, key=lambda h: len(h.edges)), "head8": head(8),
             "head16": head(16), "head32": head(32)}
    rows = []
    for name_a, name_b in (("box", "box"), ("ring12", "box"), ("ring18", "box"),
                           ("head8", "box"), ("ring18", "ring18"), ("head8", "ring18"),
                           ("head16", "box"), ("head16", "ring18"), ("head32", "box"),
                           ("head32", "ring18")):
        a, b = hulls[name_a], hulls[name_b]
        pa, ra, pb, rb = resting_poses(a, b, 400, 7, 1e-3)
        ta, tb, z = stack_hulls((a,)), stack_hulls((b,)), np.zeros(len(pa), np.int64)
        t, rot = (np.ascontiguousarray(x) for x in cc.relative_poses(pa, ra, pb, rb))
        work, out = cc.make_work(*cc.work_sizes(ta, tb)), cc.contact_rows_for(len(pa))
        row = {"a": name_a, "b": name_b, "pairs": len(a.edges) * len(b.edges)}
        for label, pairs in (("walk_s", 0), ("scan_s", 1 << 40)):
            forced = work._replace(sat=work.sat._replace(scan=np.full(1, pairs, np.int64)))

            def call(forced=forced):
                cc.contact_rows(ta.arrays, z, tb.arrays, z, t, rot, pa, ra, out, 0, len(pa),
                                forced, False)
            call()
            row[label] = _median_time(call, 7) / len(pa)
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="also write the figures here")
    parser.add_argument("--scan", action="store_true",
                        help="only the edge search's walk against its scan (SCAN_PAIRS)")
    args = parser.parse_args()
    try:
        from impactnet.models.compiled import set_threads
        set_threads(1)
    except ImportError:  # a solver without compiled kernels
        pass
    if args.scan:
        for row in scan_costs():
            print(f"{row['a']:6s} x {row['b']:6s} ({row['pairs']:5d} edge pairs): walk "
                  f"{row['walk_s'] * 1e6:6.2f} us, scan {row['scan_s'] * 1e6:6.2f} us a row")
        return
    figures = {"pairs": pair_costs(), "answers": answer_costs()}
    for row in figures["pairs"]:
        print(f"head {row['sides']:3d} on {row['on']:5s}: {row['batch_s'] * 1e6:10.1f} us/pair "
              f"in a batch of {BATCH}, {row['single_s'] * 1e6:10.1f} us alone")
    for row in figures["answers"]:
        print(f"compound_answer, spreader {row['sides']:3d} sides on a 40 ft container (detail "
              f"2): {row['batch_s'] * 1e3:8.3f} ms/pose in a batch of {row['poses']}, "
              f"{row['single_s'] * 1e3:8.3f} ms alone")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1))


if __name__ == "__main__":
    main()
