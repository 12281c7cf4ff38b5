"""Exact solver invariants, checked on every sample of a seeded fuzz run.

The default run fuzzes a few thousand first-contact poses per family; the `slow` run
(``make test`` in CI) fuzzes 40x more.
"""
import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.box.tolerances import FACE_AXIS_ANGLE_TOL, PRESSURE_FLOOR_REL
from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.geometry.poses import ORIENTATIONS, SIZE_FAMILIES, first_contact_poses
from impactnet.models.geometry.rotations import (
    quaternion_multiply,
    quaternion_to_matrix,
    random_quaternions,
)
from tests.models.box.overlap_volume import overlap_along
from tests.models.helpers import KEYS, assert_finite, point_tolerance, scale_of

#: Geometric tolerance (x pair scale): a few hundred ulps of the scale.
GEOM_TOL_REL = 1e-11
#: Swapped normals agree to this (unit vector components) where one axis clearly wins.
SWAP_NORMAL_ATOL = 1e-9
MIRRORED_TYPE = {name: "-".join(reversed(name.split("-"))) for name in CONTACT_TYPES}


def fuzz_poses(seed, per_case):
    chunks = []
    for f, family in enumerate(sorted(SIZE_FAMILIES)):
        size_a, size_b = SIZE_FAMILIES[family]
        for o, orientation in enumerate(ORIENTATIONS):
            chunks.append(first_contact_poses(
                per_case, size_a, size_b, rng=seed * 1000 + 10 * f + o,
                depth_fraction=(0.0, 0.02), separated_share=0.1, orientation=orientation,
                world_offset=np.random.default_rng(seed + f).normal(size=3) * 50))
    return {k: np.concatenate([c[k] for c in chunks]) for k in KEYS}




def check_invariants(p):
    c = box_box(*(p[k] for k in KEYS))
    scale = scale_of(p)
    tol = GEOM_TOL_REL * scale
    assert_finite(c)
    np.testing.assert_allclose(np.linalg.norm(c.normal, axis=1), 1.0, atol=1e-12)
    assert (c.depth >= 0).all()
    # The point lies inside both boxes grown by the depth and the pressure floor: the centre of
    # pressure sits at most half the depth below the reference plane, over a footprint whose
    # incident surface is at most the floor tau above that plane
    # (impactnet.models.box.kernel_pressure: the region is d + tau >= 0), so it is at most d / 2 +
    # tau from the incident box.
    grown = c.depth + PRESSURE_FLOOR_REL * scale
    for side in ("a", "b"):
        rot = quaternion_to_matrix(p[f"quaternion_{side}"])
        local = np.einsum("nij,ni->nj", rot, c.point - p[f"position_{side}"])
        excess = np.abs(local) - 0.5 * p[f"size_{side}"] - grown[:, None]
        assert (excess[c.colliding] <= tol[c.colliding, None]).all(), side
    # Separated rows say so and carry no features.
    assert (c.contact_type_code[~c.colliding] == 0).all()
    assert (c.feature_a[~c.colliding] == -1).all()
    return c


def check_swap(p, c):
    s = box_box(p["size_b"], p["position_b"], p["quaternion_b"],
                p["size_a"], p["position_a"], p["quaternion_a"])
    tol = GEOM_TOL_REL * scale_of(p)
    np.testing.assert_array_equal(s.colliding, c.colliding)
    hit = c.colliding
    # The normal flips, except where A's and B's parallel faces tie: then each call answers
    # its own A's face, and the two normals differ by the faces' tilt (seed 2 of the long
    # fuzz: 1.9e-9 rad) at equal overlap along both.
    differ = hit & (np.abs(s.normal + c.normal).max(axis=1) > SWAP_NORMAL_ATOL)
    args = tuple(p[k] for k in KEYS)
    gap = np.abs(overlap_along(-s.normal, args) - overlap_along(c.normal, args))
    assert (gap[differ] <= tol[differ]).all(), np.flatnonzero(differ & (gap > tol))[:5]
    sine = np.linalg.norm(np.cross(s.normal, c.normal), axis=1)
    assert (sine[differ] <= np.sin(FACE_AXIS_ANGLE_TOL)).all()
    np.testing.assert_allclose(s.depth, c.depth, atol=tol.max())
    np.testing.assert_array_equal(s.feature_a[hit], c.feature_b[hit])
    np.testing.assert_array_equal(s.feature_b[hit], c.feature_a[hit])
    mirrored = np.array([MIRRORED_TYPE[t] for t in c.contact_type[hit]])
    np.testing.assert_array_equal(s.contact_type[hit], mirrored)
    err = np.linalg.norm(s.point - c.point, axis=1)
    assert (err[hit] <= point_tolerance(p, c.depth)[hit]).all()


def check_rigid_motion(p, c, rng):
    n = len(c)
    q = random_quaternions(n, rng)
    rot = quaternion_to_matrix(q)
    shift = rng.normal(size=(n, 3)) * 100
    moved = {k: p[k] for k in ("size_a", "size_b")}
    for side in ("a", "b"):
        moved[f"position_{side}"] = np.einsum("nij,nj->ni", rot, p[f"position_{side}"]) + shift
        moved[f"quaternion_{side}"] = quaternion_multiply(q, p[f"quaternion_{side}"])
    m = box_box(*(moved[k] for k in KEYS))
    tol = 1e-9 * scale_of(p)
    np.testing.assert_array_equal(m.colliding, c.colliding)
    hit = c.colliding
    np.testing.assert_allclose(m.normal[hit], np.einsum("nij,nj->ni", rot, c.normal)[hit],
                               atol=1e-9)
    np.testing.assert_allclose(m.depth, c.depth, atol=tol.max())
    expected = np.einsum("nij,nj->ni", rot, c.point) + shift
    err = np.linalg.norm(m.point - expected, axis=1)
    assert (err[hit] <= point_tolerance(p, c.depth)[hit]).all()
    np.testing.assert_array_equal(m.contact_type_code, c.contact_type_code)


def check_quaternion_sign(p, c):
    f = box_box(p["size_a"], p["position_a"], -p["quaternion_a"],
                p["size_b"], p["position_b"], -p["quaternion_b"])
    np.testing.assert_allclose(f.point, c.point, atol=1e-12 * 300)
    np.testing.assert_allclose(f.normal, c.normal, atol=1e-12)
    np.testing.assert_array_equal(f.contact_type_code, c.contact_type_code)
    np.testing.assert_array_equal(f.feature_b, c.feature_b)


def run_fuzz(seed, per_case):
    p = fuzz_poses(seed, per_case)
    c = check_invariants(p)
    check_swap(p, c)
    check_rigid_motion(p, c, np.random.default_rng(seed))
    check_quaternion_sign(p, c)
    return c


def test_invariants_hold_on_every_fuzz_sample():
    c = run_fuzz(seed=1, per_case=100)
    counts = np.bincount(c.contact_type_code, minlength=len(CONTACT_TYPES))
    assert (counts > 0).all(), dict(zip(CONTACT_TYPES, counts))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(2, 6))
def test_invariants_hold_on_a_long_fuzz_run(seed):
    run_fuzz(seed=seed, per_case=1000)


def test_vertex_grazing_a_plate_far_from_the_origin_stays_within_the_pressure_floor():
    """Long-fuzz seed 5 (formerly a known miss): a cube's vertex 5e-10 m into a 10 x 10 x
    0.001 m plate, 70 m from the origin. The depth floor widens the footprint by tau, so the
    point leaves the cube grown by the depth alone (by 2e-9 m) but not grown by depth + tau."""
    p = {"size_a": [[10.0, 10.0, 0.001]],
         "position_a": [[-55.1669224532766, -36.25123201222199, -39.09026286590284]],
         "quaternion_a": [[0.28737336920544804, 0.2989779103675075, -0.8028158973638169,
                           -0.4283869637649087]],
         "size_b": [[1.0, 1.0, 1.0]],
         "position_b": [[-57.38872967391678, -37.70773080034838, -36.16612328139776]],
         "quaternion_b": [[0.0020773462055753223, 0.41476894094379946, -0.8769999765675883,
                           0.242556078797359]]}
    p = {k: np.asarray(v) for k, v in p.items()}
    c = check_invariants(p)
    assert c.contact_type[0] == "face-vertex"
    assert c.depth[0] < PRESSURE_FLOOR_REL * scale_of(p)[0]
