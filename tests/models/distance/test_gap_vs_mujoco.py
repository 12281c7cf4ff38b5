"""The gap query against MuJoCo's ``mj_geomDistance`` (tests/models/distance/others.py) on
seeded poses per body kind, from touching to 1 m apart.

MuJoCo's settings: ``distmax`` 2 m (above every gap), ``ccd_tolerance`` 1e-12 and 1,000 GJK
iterations (:data:`~tests.models.distance.others.MUJOCO_CCD_TOLERANCE`). The query is asked
about the very polytopes MuJoCo collides (a box geom's corners; a mesh's float32 vertices,
placed by the geom's frame), so the two agree to rounding: distances within
:data:`MUJOCO_TOLERANCE` (MuJoCo's negative distances of the touching poses, which its float32
vertices turn into overlaps of ~1e-9 m, count as 0), and both closest points where they are
unique (the exact reference's minimising pairs meet). Measured: 1.1e-14 m in distance, 1e-12 m
in points.
"""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.compound.hull import convex_hull
from impactnet.models.distance.query import PolytopePair
from tests.models.distance.others import mujoco_gaps, mujoco_model, mujoco_vertices
from tests.models.distance.reference import reference_gaps
from tests.models.distance.scenarios import KINDS, SIZES, cases

#: Distances and unique closest points agree within this (m): MuJoCo's GJK tolerance plus the
#: rounding of both (measured 1.1e-14 m).
MUJOCO_TOLERANCE = 1e-9


def _compare(kind: str, shapes: int, poses: int, seed: int) -> dict:
    rows, worst = 0, {"distance": 0.0, "point": 0.0}
    for case in cases(kind, shapes, poses, seed):
        model, data = mujoco_model(case.vertices_a, case.vertices_b)
        vertices_a, vertices_b = mujoco_vertices(model, 0), mujoco_vertices(model, 1)
        ours = PolytopePair(vertices_a, vertices_b).gaps(
            case.position_a, case.rotation_a, case.position_b, case.rotation_b)
        distance, on_a, on_b = mujoco_gaps(model, data, case)
        ref = reference_gaps(convex_hull(vertices_a), convex_hull(vertices_b), case.position_a,
                             case.rotation_a, case.position_b, case.rotation_b)
        point = np.maximum(np.linalg.norm(on_a - ours.point_a, axis=1),
                           np.linalg.norm(on_b - ours.point_b, axis=1))
        compared = (distance > 0.0) & ~ours.colliding & (ref.spread <= 1e-10)
        worst["distance"] = max(worst["distance"],
                                np.abs(np.maximum(distance, 0.0) - ours.distance).max())
        worst["point"] = max(worst["point"], point[compared].max(initial=0.0))
        rows += len(distance)
    print(f"{kind}: {rows} rows; worst {worst}")
    assert worst["distance"] <= MUJOCO_TOLERANCE and worst["point"] <= MUJOCO_TOLERANCE
    return {"rows": rows, **worst}


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("kind", KINDS)
def test_random_poses_agree_with_mujoco(kind, size):
    shapes, poses, seed = size
    assert _compare(kind, shapes, poses, seed)["rows"] == shapes * poses
