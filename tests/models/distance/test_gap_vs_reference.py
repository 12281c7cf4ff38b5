"""The gap query against the exact polytope reference (min over vertex-face and edge-edge
pairs, tests/models/distance/reference.py) on seeded poses per body kind, from touching to 1 m
apart (scenarios.py).

Distances agree within :data:`DISTANCE_TOL`; closest points within :data:`POINT_TOL_REL` x
scale where the reference says they are unique (its minimising feature pairs' midpoints within
:data:`UNIQUE_SPREAD` of each other); where the closest points are a whole polygon (the flat
cases) the midpoint is the reference region's centroid, within the reference's own blur
(:data:`~tests.models.distance.reference.SET_TOL_REL`). The fast tests take 300 poses a kind;
the slow ones 10,000.
"""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.compound.hull import convex_hull
from impactnet.models.distance.query import PolytopePair
from impactnet.models.distance.tolerances import SUPPORT_REL
from tests.models.distance.reference import SET_TOL_REL, reference_gaps
from tests.models.distance.scenarios import KINDS, cases, flat_cases

#: The issue's bound on the distance (m).
DISTANCE_TOL = 1e-9
#: Closest points where unique (x pair scale, m): the kernel's support slack
#: (:data:`~impactnet.models.distance.tolerances.SUPPORT_REL`). Measured: 3e-14 m; a touching
#: corner's region grows by the plane slack over the sine of its sides' angle (1e-12 m).
POINT_TOL_REL = SUPPORT_REL
#: The reference's minimising pairs all meet within this (m): the closest points are unique.
UNIQUE_SPREAD = 1e-10
#: Region centroids are compared where the gap is at least this (m): the reference's region
#: needs a direction.
REGION_MIN_GAP = 1e-6
#: The direction is checked by what it is for: the two bodies' extents along it are the
#: distance apart (a separating plane's certificate), within this (m) plus
#: :data:`CONDITIONING_M2` over the gap. A direction may differ from the reference's where the
#: closest direction is ill-conditioned (measured 5.6e-13 rad at a 1 m gap) and still certify
#: the distance to rounding.
CERTIFICATE_TOL = 1e-12
#: A vertex or edge pair's direction comes from GJK's ``v``, whose rounding (1e-16 of the
#: coordinates, m) over the gap tilts it; the certificate moves by that tilt times the bodies'
#: size (m^2: measured up to 2.6e-17 m^2, a nanometre gap's 9e-9 m).
CONDITIONING_M2 = 1e-15


def _certificate(case, ours, hull_a, hull_b) -> np.ndarray:
    """Per pose: B's lowest corner minus A's highest along the query's direction (m)."""
    world_a = np.einsum("pij,vj->pvi", case.rotation_a, hull_a.vertices) + case.position_a[:, None]
    world_b = np.einsum("pij,vj->pvi", case.rotation_b, hull_b.vertices) + case.position_b[:, None]
    along_a = np.einsum("pvi,pi->pv", world_a, ours.direction).max(axis=1)
    return np.einsum("pvi,pi->pv", world_b, ours.direction).min(axis=1) - along_a

def _errors(case) -> dict:
    """The worst errors of one case against the reference (m, dimensionless for directions)
    and the counts they cover."""
    ours = PolytopePair(case.vertices_a, case.vertices_b).gaps(
        case.position_a, case.rotation_a, case.position_b, case.rotation_b)
    hull_a, hull_b = convex_hull(case.vertices_a), convex_hull(case.vertices_b)
    ref = reference_gaps(hull_a, hull_b, case.position_a, case.rotation_a, case.position_b,
                         case.rotation_b)
    unique = ref.spread <= UNIQUE_SPREAD
    point = np.maximum(np.linalg.norm(ours.point_a - ref.point_a, axis=1),
                       np.linalg.norm(ours.point_b - ref.point_b, axis=1))
    separated = ~ours.colliding
    scale = max(hull_a.half_extent, hull_b.half_extent)
    blur = np.sqrt(2.0 * ref.distance * SET_TOL_REL * scale) + POINT_TOL_REL * scale
    region = ~unique & (ref.distance > REGION_MIN_GAP)
    certificate = np.abs(_certificate(case, ours, hull_a, hull_b) - ref.distance) / (
        CERTIFICATE_TOL + CONDITIONING_M2 / np.maximum(ref.distance, 1e-300))
    return {
        "poses": len(ref.distance),
        "distance": np.abs(ours.distance - ref.distance).max(),
        "target": np.abs(ref.distance - case.gap).max(),
        "unique": int(unique.sum()),
        "point": point[unique].max(initial=0.0) / (POINT_TOL_REL * scale),
        "point_m": point[unique].max(initial=0.0),
        "direction": certificate[separated].max(initial=0.0),
        "region": int(region.sum()),
        "centroid": (np.linalg.norm(ours.point - ref.point, axis=1) / blur)[region].max(
            initial=0.0),
        "colliding": bool((ours.colliding == (ref.distance <= 1e-12 * scale)).all()),
    }


def _check(case_list, name: str) -> dict:
    found = [_errors(case) for case in case_list]
    worst = {key: max(f[key] for f in found) for key in ("distance", "target", "point",
                                                          "point_m", "direction", "centroid")}
    counts = {key: sum(f[key] for f in found) for key in ("poses", "unique", "region")}
    print(f"{name}: {counts} worst {worst}")
    assert all(f["colliding"] for f in found)
    assert worst["distance"] <= DISTANCE_TOL
    assert worst["target"] <= DISTANCE_TOL
    assert worst["point"] <= 1.0
    assert worst["direction"] <= 1.0
    assert worst["centroid"] <= 1.0
    return counts


@pytest.mark.parametrize("kind", KINDS)
def test_random_poses_of_each_kind_agree_with_the_exact_reference(kind):
    counts = _check(cases(kind, shapes=5, poses=60, seed=101), kind)
    assert counts["unique"] >= 280


def test_parallel_faces_answer_the_reference_region_centroid():
    counts = _check(flat_cases(shapes=5, poses=60, seed=102), "flat")
    assert counts["region"] >= 200


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_ten_thousand_poses_of_each_kind_agree_with_the_exact_reference(kind):
    counts = _check(cases(kind, shapes=100, poses=100, seed=201), kind)
    assert counts["poses"] == 10_000 and counts["unique"] >= 9_500


@pytest.mark.slow
def test_ten_thousand_flat_poses_answer_the_reference_region_centroid():
    counts = _check(flat_cases(shapes=100, poses=100, seed=202), "flat")
    assert counts["region"] >= 7_000
