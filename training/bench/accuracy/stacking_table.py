"""The stacking table: how the exact solver answers a box resting on another, per tilt.

    python -m impactnet.training.bench.accuracy.stacking_table [--rows 2000] [--seed 0]
        [--family cube] [--method exact|single|committee|auto]

For each tilt of :data:`impactnet.training.bench.contact_sets.STACKING_TILTS` (0 and 1e-12 .. 1e-2
rad), ``--rows`` poses of :func:`impactnet.training.bench.contact_sets.stacking_poses` are solved by
``impactnet.models.box.exact.box_box`` and compared with MuJoCo's box-box and with the grid centre
of pressure (:mod:`impactnet.training.bench.accuracy.vs_mujoco`); ``--method`` answers with a
learned predictor of the shipped bundle instead (``models.load_predictor``), to check that
``committee`` and ``auto`` agree with MuJoCo on stacking as well as ``exact`` does. Columns: the
share of rows answered edge-edge; the point error against MuJoCo's depth-weighted contact centroid
and against the centre-of-pressure reference (median / p99, % of the pair's shortest edge); the
share of rows more than 2 % off the centre of pressure; the share within both targets (normal within
1 deg of MuJoCo's, point within 2 % of the centre of pressure, or of MuJoCo's crossing where MuJoCo
answered an edge pair inside the face band: :mod:`impactnet.training.bench.accuracy.vs_mujoco`).
Rows that MuJoCo finds separated (B's deepest corner hangs over A's edge) are left out; "rows in
contact" counts the others, and the shares are of them. "MuJoCo edge axis": MuJoCo answered with an
edge pair. The table is printed as Markdown with the solver's point rule version (issue #11's
"before" / "after").
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from impactnet.training.bench import contact_sets as cs
from impactnet.training.bench.accuracy import vs_mujoco as vm

HEADER = ("| tilt (rad) | rows in contact | ours edge-edge | MuJoCo edge axis "
          "| point vs MuJoCo centroid % median / p99 | point vs centre of pressure % median / p99 "
          "| > 2 % off the centre of pressure | within the targets |")


def _percent(x: float) -> str:
    return f"{100.0 * x:.2f} %"


def _pair(values: np.ndarray) -> str:
    values = values[np.isfinite(values)]
    if values.size == 0:
        return "–"
    return f"{np.median(values):.3g} / {np.percentile(values, 99.0):.3g}"


def tilt_row(tilt: float, rows: int, seed: int, family: str, predictor=None) -> dict:
    """Solve and compare ``rows`` stacking poses at one tilt; returns the table's figures.

    ``predictor`` has ``impactnet.models.box.exact.box_box``'s signature (default: the exact
    solver)."""
    from impactnet.models.box.exact import box_box
    from impactnet.models.contacts import EDGE_EDGE

    size_a, size_b = cs.STACKING_FAMILIES[family]
    args = vm.pose_args(cs.stacking_poses(rows, size_a, size_b, tilt, seed))
    ours = (predictor or box_box)(*args)
    reference = vm.mujoco_reference(args)
    errors = vm.mujoco_row_errors(ours.point, ours.normal, ours.colliding, reference)
    centroid = 100.0 * np.linalg.norm(ours.point - reference.mujoco.point,
                                      axis=1) / reference.scale
    cop = 100.0 * np.linalg.norm(ours.point - reference.point, axis=1) / reference.scale
    counted = errors["counted"]
    with np.errstate(invalid="ignore"):
        off = cop > 100.0 * vm.POINT_TOL_FRACTION
    by = getattr(ours, "predictor", None)
    fallback = (float((np.asarray(by, dtype=str) == "exact")[counted].mean())
                if by is not None else None)
    return {"tilt": tilt, "rows": int(counted.sum()), "exact_share": fallback,
            "edge_edge": float((ours.contact_type_code == EDGE_EDGE)[counted].mean()),
            "mujoco_edge": float(reference.edge_axis[counted].mean()),
            "vs_centroid": centroid[counted], "vs_cop": cop[counted],
            "off": float(off[counted].mean()), "within": float(errors["within"][counted].mean())}


def markdown(figures: list[dict], family: str, method: str = "exact") -> str:
    """The table, one line per tilt."""
    lines = [f"Stacking, {family}, answered by {method}: B on A's top face (offset "
             f"±{cs.STACKING_OFFSET_FRACTION:g} of A's length and width, uniform yaw, pushed "
             f"{1e3 * cs.STACKING_PUSH_M[0]:g}-"
             f"{1e3 * cs.STACKING_PUSH_M[1]:g} mm); errors in % of the pair's shortest edge.",
             "", HEADER, "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for f in figures:
        lines.append(f"| {f['tilt']:g} | {f['rows']:,} | {_percent(f['edge_edge'])} | "
                     f"{_percent(f['mujoco_edge'])} | {_pair(f['vs_centroid'])} | "
                     f"{_pair(f['vs_cop'])} | {_percent(f['off'])} "
                     f"| {_percent(f['within'])} |")
    shares = [f["exact_share"] for f in figures if f.get("exact_share") is not None]
    if shares and method != "exact":
        lines += ["", f"{method}: rows answered by the exact solver (its fallback), per tilt: "
                  + ", ".join(_percent(x) for x in shares) + "."]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m impactnet.training.bench.accuracy.stacking_table",
        description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=2000, help="poses per tilt (default 2000)")
    parser.add_argument("--seed", type=int, default=0, help="pose seed (default 0)")
    parser.add_argument("--family", default="cube", choices=sorted(cs.STACKING_FAMILIES),
                        help="box pair (default cube)")
    parser.add_argument("--method", default="exact",
                        choices=("exact", "single", "committee", "auto"),
                        help="who answers (default exact; the others load the shipped bundle)")
    args = parser.parse_args(argv)
    missing = vm.mujoco_missing()
    if missing:
        parser.error(missing)
    import impactnet.models.contacts

    predictor = None
    if args.method != "exact":
        from impactnet.models import load_predictor

        predictor = load_predictor(args.method)
    started = time.perf_counter()
    figures = [tilt_row(tilt, args.rows, args.seed + k, args.family, predictor)
               for k, tilt in enumerate(cs.STACKING_TILTS)]
    print(markdown(figures, args.family, args.method))
    rule = getattr(impactnet.models.contacts, "POINT_RULE_VERSION", 1)
    print(f"\n(point rule version {rule}, solver {impactnet.models.contacts.__file__}; "
          f"{time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
