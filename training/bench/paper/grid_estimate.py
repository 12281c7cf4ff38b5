"""The paper's Section II estimate of the grid a polygon method needs, against the measurement.

The text (the formulas are lost in the extraction; the reading below is ours): "Let us consider
a cube with edges of length L. The desired error must be less than a factor r of the cube edge
L [err = r L] ... the built grid has to be composed of squares with diagonals of length d < err.
As [d = sqrt(2) L / n, n = E[sqrt(2) / r] + 1] where E[.] denotes the integer part. ... the
number of squares (and therefore of triangles) per face has a growth of order [1 / r^2]."

So the estimate is: a grid of n x n squares per face locates the impact point to within one
square's diagonal, relative error ``r(n) = sqrt(2) / n``, and a target r needs
``n(r) = E[sqrt(2) / r] + 1`` squares per edge, ``2 n^2`` triangles per face.

The check (:func:`check`): for each target r, the smallest n of the sweep whose measured point
error (median, and p99) is within r of the edge, next to n(r); and for each n, the share of
poses whose error is within the bound (the largest cell diagonal of either box, which is
``sqrt(2) L / n`` for the cubes).
"""
from __future__ import annotations

import math

#: Relative precisions r (fraction of the edge) at which the estimate is checked.
TARGETS = (0.2, 0.1, 0.05, 0.02, 0.01)


def grid_needed(r: float) -> int:
    """The paper's n(r) = E[sqrt(2) / r] + 1 squares per face edge."""
    return math.floor(math.sqrt(2.0) / r) + 1


def bound_pct(n: int) -> float:
    """The paper's relative error bound of an n x n grid, sqrt(2) / n, in per cent."""
    return 100.0 * math.sqrt(2.0) / n


def _smallest_n(rows, key: str, target_pct: float) -> int | None:
    for row in sorted(rows, key=lambda r: r.info["grid"]):
        value = (row.errors or {}).get(key)
        if value is not None and value <= target_pct and row.errors["miss_rate"] == 0.0:
            return int(row.info["grid"])
    return None


def check(rows) -> dict:
    """The estimate against the polygon rows (measure.Row) of every pose set."""
    polygon = [r for r in rows if r.family == "polygon" and r.status == "ok"]
    sets = sorted({r.pose_set for r in polygon})
    by_n = []
    for row in sorted(polygon, key=lambda r: (r.pose_set, r.info["grid"])):
        n = int(row.info["grid"])
        by_n.append({"pose_set": row.pose_set, "n": n, "triangles_per_box": 12 * n * n,
                     "paper_bound_pct": bound_pct(n), "us_n1": row.us_n1,
                     "us_per_pair": row.us_per_pair,
                     "contacts_per_pair_median": row.info.get("contacts_per_pair_median"),
                     "point_pct_median": row.errors["point_pct_median"],
                     "point_pct_p99": row.errors["point_pct_p99"],
                     "normal_deg_median": row.errors["normal_deg_median"],
                     "normal_deg_p99": row.errors["normal_deg_p99"],
                     "miss_rate": row.errors["miss_rate"],
                     "within_cell_diagonal": row.info.get("within_cell_diagonal")})
    targets = []
    for r in TARGETS:
        entry = {"r": r, "paper_n": grid_needed(r), "paper_triangles_per_face":
                 2 * grid_needed(r) ** 2}
        for name in sets:
            mine = [row for row in polygon if row.pose_set == name]
            entry[f"{name}_median_n"] = _smallest_n(mine, "point_pct_median", 100 * r)
            entry[f"{name}_p99_n"] = _smallest_n(mine, "point_pct_p99", 100 * r)
        targets.append(entry)
    return {"reading": "d = sqrt(2) L / n < r L  =>  n = E[sqrt(2) / r] + 1; triangles per "
                       "face 2 n^2, growing as 1 / r^2",
            "pose_sets": sets, "by_n": by_n, "targets": targets,
            "note": "measured n: the smallest grid of the sweep with no missed contact and a "
                    "point error (median or p99) within r of the shortest edge; – (None in "
                    "JSON): not reached by the largest grid"}
