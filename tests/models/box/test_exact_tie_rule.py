"""The tie rule between face and edge axes (models/box/kernel_sat.py, rules 1-3) and its
documented worst case.

The figures of models/box/kernel_sat.py's docstring are backed here by measurements on first-contact
fuzz (``impactnet.models.geometry.poses.first_contact_poses``: every size family, every orientation
family) and by scenarios whose answer is known by hand. ``c`` is the least overlap over the 15 SAT
axes (the true penetration depth), ``u`` its axis; the worst case allowed is
``max(DEPTH_GAIN_TOL_REL x scale, 2 FACE_AXIS_ANGLE_TOL (rho_A + rho_B))``, rho a box's half
diagonal.

Measured on the default run (seed 1000, 3000 poses x 28 cases = 84,000; the slow run, seed
1001, 20,000 x 28 = 560,000, in brackets):

* the reported depth exceeds c by at most 4.0e-7 [3.8e-7] of the pair's scale, 1.2e-5 [1.1e-5]
  of the worst case; the SAT overlap along the chosen axis, which a face contact does not
  report (it reports its region's deepest point), by up to 0.45 [0.54] of the worst case,
  1.0e-2 [1.6e-2] of the scale;
* rule 1 rejects the least-penetration edge pair on 22,372 [149,868] rows (27 %, mostly the
  near-parallel families); the face answering is then at most 0.00999 [0.0099991] rad from it;
* the 21,915 [146,615] edge-edge answers cross at least 3.3e-5 [5.7e-6] of the scale inside
  both edges: rule 3's slack (1e-9) is never used.
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.box import tolerances as tol
from impactnet.models.box.decision import axis_table
from impactnet.models.box.exact import box_box, prepare_inputs
from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.poses import ORIENTATIONS, SIZE_FAMILIES, first_contact_poses
from tests.models.box.overlap_volume import centre_of_pressure
from tests.models.box.sweeps import CUBE, random_axes, resting_poses
from tests.models.helpers import KEYS

SEED = 1000
#: Poses per (size family, orientation family): 28 cases.
PER_CASE, PER_CASE_SLOW = 3000, 20000
PHI = tol.FACE_AXIS_ANGLE_TOL
#: Rounding (x pair scale, metres) of an overlap or a depth computed along two paths: a few
#: hundred ulps of the scale (measured: 1.1e-15).
ROUNDING_REL = 1e-13
#: Rounding (radians) of the angle between two unit axes; the band itself is tested on a
#: cosine, exact to ~1e-16 / phi.
ANGLE_ROUNDING_RAD = 1e-9
#: The reported depth's measured excess over c (x pair scale), as models/box/kernel_sat.py states
#: (4.4e-7 on 560,000 poses), with margin: a regression to reporting the SAT overlap along a
#: leaning face (up to 0.45 of the worst case, ~1e-2 of the scale) fails it.
MEASURED_EXCESS_REL = 1e-6
#: Rows within this fraction of the band's edge (relative angle) are left out of the rule-1
#: split: the solver tests the band on a cosine, this test on an angle.
BAND_EDGE_REL = 1e-9
#: Agreement (x pair scale, metres) of an edge-edge point with the closest points computed
#: here from the features (another float64 formula of a conditioned 2 x 2 solve).
EDGE_POINT_TOL_REL = 1e-9
#: Push depth (metres) of the scenarios.
PRESS = 1e-3
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def fuzz(per_case, seed=SEED):
    """First-contact poses of every family (inputs validated), the solver's answers and its
    internals: overlaps (15, n), the chosen axis, the unit normal and least axis (A's frame,
    as lines: unoriented), the pair scales."""
    chunks = [first_contact_poses(per_case, *SIZE_FAMILIES[family], rng=seed + 10 * f + o,
                                  orientation=orientation)
              for f, family in enumerate(sorted(SIZE_FAMILIES))
              for o, orientation in enumerate(ORIENTATIONS)]
    raw = [np.concatenate([c[k] for c in chunks]) for k in KEYS]
    inputs = prepare_inputs(*raw)
    contacts = box_box(*raw)
    overlap, units, scale = axis_table(*raw)
    rows = np.arange(len(scale))
    axis = contacts.axis
    least_axis = overlap.argmin(axis=1).astype(np.int8)
    rho = 0.5 * (np.linalg.norm(inputs[0], axis=1) + np.linalg.norm(inputs[3], axis=1))
    worst = np.maximum(tol.DEPTH_GAIN_TOL_REL * scale, 2 * PHI * rho)
    return dict(inputs=inputs, contacts=contacts, units=units, scale=scale,
                overlap=overlap.T, axis=axis, normal=units[rows, axis].T,
                least_axis=least_axis, least_unit=units[rows, least_axis].T, worst=worst)


@pytest.fixture(scope="module", params=[PER_CASE, pytest.param(PER_CASE_SLOW,
                                                                 marks=pytest.mark.slow)])
def fuzzed(request):
    """The default fuzz (seed SEED), and the slow run's (seed SEED + 1)."""
    return fuzz(request.param, seed=SEED + (request.param == PER_CASE_SLOW))


def axis_angle(u, v):
    """Angle (radians) between the lines of unit vectors u and v (3, n)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v, axis=0), axis=0), np.abs((u * v).sum(0)))


def test_first_contact_fuzz_depth_exceeds_the_least_overlap_by_at_most_the_worst_case(fuzzed):
    """(a) On every row the reported depth lies between c and the overlap along the chosen
    axis, and exceeds c by at most the documented worst case (measured: 4.0e-7 x scale, 1.2e-5
    of the worst case; the chosen axis's SAT overlap: 0.45 of it)."""
    f = fuzzed
    c, scale, rows = f["contacts"], f["scale"], np.arange(len(f["axis"]))
    assert c.colliding.all()
    least = np.maximum(f["overlap"].min(axis=0), 0.0)
    along_axis = np.maximum(f["overlap"][f["axis"], rows], 0.0)
    rounding = ROUNDING_REL * scale
    assert (c.depth >= least - rounding).all() and (c.depth <= along_axis + rounding).all()
    excess = ((c.depth - least) / f["worst"]).max()
    sat_excess = ((along_axis - least) / f["worst"]).max()
    assert excess <= 1.0 and sat_excess <= 1.0, (
        f"depth - c up to {excess:.3g}, SAT overlap - c up to {sat_excess:.3g} x the worst "
        "case (measured: 1.2e-5 and 0.45)")
    measured = ((c.depth - least) / scale).max()
    assert measured <= MEASURED_EXCESS_REL, f"depth - c up to {measured:.3g} x scale (4.0e-7)"


def test_a_rejected_edge_pair_leaves_the_normal_within_the_band(fuzzed):
    """(b) Where the least-penetration axis is an edge pair inside the band of the
    least-overlap face (rule 1), that face answers: its normal within phi of the edge pair's
    (measured: up to 0.0100 rad, the band's edge)."""
    f = fuzzed
    face = f["overlap"][:6].argmin(axis=0).astype(np.int8)
    to_face = axis_angle(f["least_unit"], f["units"][np.arange(len(face)), face].T)
    rejected = (f["least_axis"] >= 6) & (to_face <= PHI * (1 - BAND_EDGE_REL))
    assert rejected.sum() > 1000, rejected.sum()
    assert (f["axis"][rejected] < 6).all()
    # impactnet.models.contacts.EDGE_EDGE
    assert (f["contacts"].contact_type_code[rejected] != 3).all()
    angle = axis_angle(f["normal"], f["least_unit"])[rejected].max()
    assert angle <= PHI + ANGLE_ROUNDING_RAD, f"normal {angle} rad off the edge pair (0.00999)"
    outside = (f["least_axis"] >= 6) & (to_face > PHI * (1 + BAND_EDGE_REL))
    assert (f["axis"][outside] == f["least_axis"][outside]).all()  # outside: the edge pair


def test_edge_edge_answers_cross_inside_both_edges(fuzzed):
    """(d) Rule 3, checked from the reported features alone: the closest points of the lines
    of the two edges lie inside both segments (within EDGE_INSIDE_TOL_REL x scale), and the
    point is their midpoint."""
    c, (size_a, position_a, qa, size_b, position_b, qb) = fuzzed["contacts"], fuzzed["inputs"]
    rows = np.flatnonzero(c.contact_type_code == 3)
    assert len(rows) > 10000
    ends = []
    for size, position, q, feature in ((size_a, position_a, qa, c.feature_a),
                                       (size_b, position_b, qb, c.feature_b)):
        rot = Rotation.from_quat(q[rows], scalar_first=True).as_matrix()
        edge = feature[rows] - bf.EDGE_BASE
        centre = position[rows] + np.einsum("nij,nj->ni", rot, bf.edge_centers(size[rows])[
            np.arange(len(rows)), edge])
        ends.append((centre, np.einsum("nij,nj->ni", rot, bf.edge_directions()[edge]),
                     0.5 * bf.edge_lengths(size[rows])[np.arange(len(rows)), edge]))
    (p, d, half_p), (q, e, half_q) = ends
    w, b = p - q, (d * e).sum(1)
    s = (b * (e * w).sum(1) - (d * w).sum(1)) / (1 - b * b)
    t = ((e * w).sum(1) - b * (d * w).sum(1)) / (1 - b * b)
    scale = 0.5 * (size_a[rows].max(1) + size_b[rows].max(1))
    margin = np.minimum(half_p - np.abs(s), half_q - np.abs(t)) / scale
    assert margin.min() >= -tol.EDGE_INSIDE_TOL_REL, (
        f"{margin.min():.3g} x scale inside an edge (measured: 3.3e-5 inside)")
    midpoint = 0.5 * (p + s[:, None] * d + q + t[:, None] * e)
    error = np.linalg.norm(c.point[rows] - midpoint, axis=1) / scale
    assert error.max() <= EDGE_POINT_TOL_REL, error.max()


def ridge_pose(cross_deg):
    """A (2 m cube turned 45 deg about y: ridge along y at z = sqrt 2) under B (the same turned
    45 deg about x, then yawed so that its lower ridge crosses A's at ``cross_deg``), PRESS
    deep: both present an edge, the cross axis is vertical, 45 deg from every face normal."""
    qa = Rotation.from_euler("y", 45, degrees=True).as_quat(scalar_first=True)
    qb = (Rotation.from_euler("z", 90 - cross_deg, degrees=True)
          * Rotation.from_euler("x", 45, degrees=True)).as_quat(scalar_first=True)
    return [2.0, 2, 2], [0.0, 0, 0], qa, [2.0, 2, 2], [0.0, 0, 2 * np.sqrt(2) - PRESS], qb


@pytest.mark.parametrize("cross_deg", [90, 60, 30, 10])
def test_crossed_ridges_stay_edge_edge(cross_deg):
    """(c) Crossed edges, each box presenting one: edge-edge at the crossing, whatever the
    crossing angle, with the hand answer (normal +z, depth PRESS, point half-way)."""
    c = box_box(*ridge_pose(cross_deg))
    assert c.contact_type[0] == "edge-edge"
    np.testing.assert_allclose(c.normal[0], [0, 0, 1], atol=1e-12)
    assert c.depth[0] == pytest.approx(PRESS, abs=1e-12)
    np.testing.assert_allclose(c.point[0], [0, 0, np.sqrt(2) - PRESS / 2], atol=1e-12)


def rim_pose(slope):
    """B (2 m cube turned 45 deg about y: lower ridge along y, then tilted by ``slope`` rad
    about x so that the ridge descends towards +y) crosses the rim of A's top face (the edge
    along x at y = z = 1) with the ridge's middle PRESS below it along n = (0, sin, cos) (the
    cross axis, ``slope`` from A's face normal). Returns the six inputs and n."""
    rot = Rotation.from_euler("x", -slope) * Rotation.from_euler("y", 45, degrees=True)
    matrix = rot.as_matrix()
    lowest = min(([sx, 0.0, sz] for sx in (-1, 1) for sz in (-1, 1)),
                 key=lambda m: (matrix @ m)[2])  # the ridge's middle, B's frame
    n = np.array([0.0, np.sin(slope), np.cos(slope)])
    centre = np.array([0.0, 1.0, 1.0]) - PRESS * n - matrix @ lowest
    return ([2.0, 2, 2], np.zeros(3), IDENTITY, [2.0, 2, 2], centre,
            rot.as_quat(scalar_first=True)), n


@pytest.mark.parametrize("slope", [1.5 * PHI, 3 * PHI, 0.1, 0.3, 0.6])
def test_ridge_over_a_rim_above_the_band_stays_edge_edge(slope):
    """(c) Skewed edges whose cross axis leans on A's top face by more than the band: the
    edge pair is shallower than the face by ~sin(slope) and answers, at the rim's crossing."""
    args, n = rim_pose(slope)
    c = box_box(*args)
    assert c.contact_type[0] == "edge-edge"
    np.testing.assert_allclose(c.normal[0], n, atol=1e-12)
    assert c.depth[0] == pytest.approx(PRESS, abs=1e-12)
    np.testing.assert_allclose(c.point[0], [0, 1, 1] - PRESS / 2 * n, atol=1e-12)


@pytest.mark.parametrize("slope", [0.5 * PHI, 0.9 * PHI])
def test_ridge_over_a_rim_inside_the_band_answers_the_face(slope):
    """Inside the band the same contact is A's face: normal +z (``slope`` from the edge pair),
    depth the region's deepest point (the ridge at the rim, PRESS / cos(slope) below the
    face: c plus 1.25e-8 m at 0.005 rad), point the centre of pressure of the ridge's wedge."""
    args, n = rim_pose(slope)
    c = box_box(*args)
    assert c.contact_type[0] in ("face-edge", "face-vertex")
    np.testing.assert_array_equal(c.normal[0], [0, 0, 1])
    assert np.arccos(c.normal[0] @ n) <= PHI
    assert c.depth[0] == pytest.approx(PRESS / np.cos(slope), rel=1e-12)
    rho = 2 * np.sqrt(3.0)
    assert c.depth[0] - PRESS <= 2 * PHI * rho
    rot_b = Rotation.from_quat(args[5], scalar_first=True).as_matrix()
    floor = PRESSURE_FLOOR_REL * 2.0
    expected = centre_of_pressure(([2.0, 2, 2], np.zeros(3), np.eye(3)),
                                  (args[3], args[4], rot_b), [0, 0, 1], floor)
    np.testing.assert_allclose(c.point[0], expected, atol=1e-12)


@pytest.mark.parametrize("tilt", [1e-12, 1e-9, 1e-6, 1e-4])
def test_cube_on_cube_tilted_with_overhang_answers_a_face(tilt):
    """(e) Issue #11: a 2 m cube resting on another, tilted about a random horizontal axis,
    yawed at random and overhanging (its centre up to 1.2 m off in x and y: B still covers
    part of A's face, and reaches up to 1.4 m past its edges): A's top edges x B's bottom
    edges lie within the tilt of the vertical, so the contact is a face one, its normal the
    vertical to the tilt and its depth the resting depth to tilt x the cube's diagonal."""
    rng = np.random.default_rng(SEED + int(-np.log10(tilt)))
    n = 2000
    # 1-10 mm deep: more than the tilt lifts B's face over its 2.8 m diagonal (the lowest
    # corner may hang past A's edge), so that every pair touches.
    depth = np.exp(rng.uniform(np.log(1e-3), np.log(1e-2), n))
    poses = resting_poses(CUBE, CUBE, depth, rng.uniform(-1.2, 1.2, (n, 2)),
                          rng.uniform(-np.pi, np.pi, n), tilt, random_axes(rng, n, True))
    c = box_box(*(poses[k] for k in KEYS))
    assert c.colliding.all()
    assert (c.contact_type_code != 3).all(), np.flatnonzero(c.contact_type_code == 3)[:5]
    assert (np.abs(c.normal[:, 2]) >= np.cos(tilt) - 1e-15).all()
    np.testing.assert_allclose(c.depth, depth, rtol=0, atol=tilt * 2 * np.sqrt(3) + 1e-15)
