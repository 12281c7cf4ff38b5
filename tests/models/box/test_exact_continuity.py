"""Continuity of the exact solver's answer in the pose (issues #11 and #18).

The point is the centre of pressure (CoP) of the overlap footprint (docs/design.md): continuous in
the pose across face-face, edge-face and vertex-face, and a face contact tilted by a tiny angle
stays that face contact (the face/edge tie rule of :mod:`impactnet.models.box.sat`). B rests on A's
top face (:mod:`tests.models.box.sweeps`: A at the origin, level; B's lowest corner kept ``d`` deep
by a pivot on the contact). Symbols: L the larger body's largest edge (m), d the depth (m), theta a
tilt and psi a yaw (rad), x a shift (m). Sections: A stacking with a slight tilt (#11), B continuity
sweeps (#18), C swapping A and B, D batch against single pairs, E exactly touching features (and no
NaN anywhere: every solve checks it).
"""
import functools

import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.contacts import CONTACT_TYPE_CODES, EDGE_EDGE
from impactnet.models.geometry.rotations import quaternion_to_matrix
from tests.models.box import sweeps as sw
from tests.models.helpers import KEYS, assert_finite, point_tolerance, scale_of

#: Issue #11 regime (dimensionless): tilts with theta L <= this times d vary the depth over the
#: face by at most 1 %; the contact there is the level one.
STACK_TILT_FRACTION = 0.01
#: Point agreement with the level answer in that regime (x L, the longer face edge): the CoP
#: leaves the footprint's centroid by theta Var / d <= theta L^2 / (9 d) = 0.11 % of L there.
STACK_POINT_FRACTION = 5e-3
#: Normal agreement in that regime (x theta): A's and B's face normals are both within theta.
STACK_NORMAL_TILTS = 2.0
#: Convergence (dimensionless): |p(theta) - p(0)| <= this * theta L (1 + L / d); the outline
#: moves by about theta L, the CoP within it by theta L^2 / (9 d).
CONVERGENCE_LEVER = 1.0
#: Angle floor (rad) of normals computed from rotated axes: about 50 ulps of 1.
NORMAL_NOISE = 1e-14
#: Depth floor (m per metre of pair scale): rounding of the overlaps, a few hundred ulps.
DEPTH_NOISE_REL = 1e-13
#: Step floor (x L): rounding of neighbouring points, as tests.models.helpers.POINT_TOL_REL.
STEP_NOISE_REL = 1e-9
#: Shift or yaw (dimensionless): |dp| <= C (dx + L dpsi). A footprint's centroid slides along
#: a long footprint faster than the edge that cuts it (1 / sin of their angle); the worst of
#: 1,600 random reference sweeps (independent CoP code, these stacks) was 2.3.
C_SLIDE = 5.0
#: Tilt (dimensionless): |dp| <= C (L^2 / d) dtheta. A wedge footprint of width w = d / theta
#: has its CoP at w / 3, which moves by w^2 / (3 d) <= L^2 / (3 d) per radian.
C_TILT = 1.0
#: Depth (dimensionless): |dp| <= C (L / d) dd; the same wedge moves by w / (3 d) per metre.
C_DEPTH = 1.0
#: README sweep (m): the spreader's point may move this much per yaw step (old code: 1.20 m).
README_STEP_M = 2e-3
#: CoP of a vertex-down cube off its vertex (x d |delta|): 1.5 measured (reference code).
VERTEX_LEVER = 3.0
#: Face type <-> edge-edge (x d): both points lie in the overlap around a vertex d deep, whose
#: faces rise 1 in sqrt(2), so within sqrt(2) d of it: at most 2 sqrt(2) d apart.
TYPE_CHANGE_JUMP_D = 3.0
#: Swap at parallel faces (x theta d): A's and B's face give the same overlap volume; their
#: points are its centroid moved to each face's mid-surface along normals theta apart.
SWAP_TIE_LEVER = 4.0
#: Exactly touching faces (m): their area centroid under a uniform pressure, up to rounding.
TOUCH_TOL = 1e-9
#: Exactly touching edges and vertices (x pair scale / slope, m): touching is defined to a
#: depth floor (the solver's is 1e-9 of the scale, far below what a simulator resolves), which
#: spreads a feature over floor / slope on the face, and rounding of that thin region; 10x.
TOUCH_REL = 1e-8

FACE_CODES = [CONTACT_TYPE_CODES[t] for t in ("face-face", "face-edge", "edge-face",
                                              "face-vertex", "vertex-face")]
TILTS = np.concatenate([[0.0], np.geomspace(1e-3, 1e-12, 10)])
STACK_FAMILIES = ("cube_on_cube", "c20_on_c40", "c40_on_c40", "needle_on_slab")
STACK_COUNT = 64  # random stacks per family, each at every tilt of TILTS
SWEEP_KINDS = ("yaw", "shift", "tilt", "depth")
SWEEP_COUNT, SWEEP_POINTS = 4, 301  # random sweeps per family and kind, poses per sweep
VERTEX_AXES = sw.random_axes(np.random.default_rng(7), 6)  # turns through the 3-face tie
SEEDS = [0, *(pytest.param(seed, marks=pytest.mark.slow) for seed in range(1, 9))]
SWAPPED = ("size_b", "position_b", "quaternion_b", "size_a", "position_a", "quaternion_a")


def solve(poses, keys=KEYS):
    """`box_box` of a batch of poses (``keys`` picks the argument order); no NaN anywhere."""
    contacts = box_box(*(poses[key] for key in keys))
    assert_finite(contacts)
    return contacts


# A. Stacking with a slight tilt (issue #11) ---------------------------------------------------
@functools.cache
def stacking(family, seed=0):
    """The issue #11 poses of a family, their contacts and each row's level (theta 0) row."""
    rng = np.random.default_rng([seed, 110 + STACK_FAMILIES.index(family)])
    made = sw.tilted_stacks(*sw.STACKS[family], rng, STACK_COUNT, TILTS)
    level = np.repeat(np.arange(STACK_COUNT) * len(TILTS), len(TILTS))
    return made, solve(made.poses), level


def negligible(made):
    """Rows in the issue #11 regime (theta L <= 1 % of d), the level rows included."""
    return made.param * made.scale <= STACK_TILT_FRACTION * made.depth


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("family", STACK_FAMILIES)
def test_stack_tilted_about_random_axes_converges_to_the_level_answer(family, seed):
    made, c, level = stacking(family, seed)
    theta, d, scale = made.param, made.depth, made.scale
    rows = negligible(made)
    err = np.linalg.norm(c.point - c.point[level], axis=1)
    bound = CONVERGENCE_LEVER * theta * scale * (1 + scale / d) + point_tolerance(made.poses, d)
    worst = np.argmax(err / bound * rows)
    assert (err <= bound)[rows].all(), (
        f"{(err > bound)[rows].sum()} rows; worst theta {theta[worst]:.1e}, d {d[worst]:.1e}:"
        f" {err[worst]:.3e} m > {bound[worst]:.3e} m")
    depth_err = np.abs(c.depth - d)
    assert (depth_err <= theta * scale + DEPTH_NOISE_REL * scale)[rows].all(), depth_err.max()


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("family", STACK_FAMILIES)
def test_stack_tilted_by_a_negligible_angle_stays_a_face_contact_near_the_level_answer(family,
                                                                                       seed):
    made, c, level = stacking(family, seed)
    rows, theta = negligible(made), made.param
    types = c.contact_type[rows]
    assert np.isin(c.contact_type_code[rows], FACE_CODES).all(), dict(
        zip(*np.unique(types, return_counts=True)))
    err = np.linalg.norm(c.point - c.point[level], axis=1)[rows]
    assert err.max() <= STACK_POINT_FRACTION * made.scale, f"{err.max():.4f} m"
    angle = sw.angle_between(c.normal, c.normal[level])
    excess = (angle - STACK_NORMAL_TILTS * theta - NORMAL_NOISE)[rows]
    assert (excess <= 0).all(), f"normal off by {angle[rows][excess.argmax()]:.2e} rad"


# B. Continuity sweeps (issue #18) -------------------------------------------------------------
def test_spreader_on_container_yaw_sweep_point_moves_at_most_2mm_per_step():
    made = sw.yaw_sweep(sw.C40, sw.SPREADER, (0.3, 0.1, 1.69), np.linspace(0, 0.05, 2001))
    c = solve(made.poses)
    step = sw.steps(c.point)
    i = step.argmax()
    assert c.colliding.all() and np.isin(c.contact_type_code, FACE_CODES).all()
    assert step[i] <= README_STEP_M, (
        f"{step[i] * 1e3:.3f} mm at yaw {made.param[i]:.5f} -> {made.param[i + 1]:.5f} rad")


def test_cube_on_cube_yaw_sweep_point_moves_at_most_c_slide_l_dpsi_per_step():
    # Old code: a 0.27 m jump at yaw 0.184 rad.
    made = sw.yaw_sweep(sw.CUBE, sw.CUBE, (0.3, 0.2, 1.99), np.linspace(0, 0.3, 2001))
    step = sw.steps(solve(made.poses).point)
    bound = C_SLIDE * made.scale * np.diff(made.param) + STEP_NOISE_REL * made.scale
    i = np.argmax(step / bound)
    assert step[i] <= bound[i], f"{step[i]:.4f} m at yaw {made.param[i]:.5f} rad"


@functools.cache
def family_sweeps(family, seed=0):
    """Random yaw, shift, tilt and depth sweeps of a stack, as (kind, sweep) and contacts."""
    rng = np.random.default_rng([seed, 180 + list(sw.STACKS).index(family)])
    made = [(kind, s) for kind in SWEEP_KINDS
            for s in sw.random_sweeps(*sw.STACKS[family], kind, rng, SWEEP_COUNT, SWEEP_POINTS)]
    return made, solve(sw.concatenate([s for _, s in made]))


def step_bound(kind, made):
    """Allowed move (m) between neighbouring poses of a sweep, shape (n - 1,)."""
    step, scale = np.abs(np.diff(made.param)), made.scale
    depth = np.minimum(made.depth[1:], made.depth[:-1])
    lever = {"yaw": C_SLIDE * scale, "shift": C_SLIDE, "tilt": C_TILT * scale**2 / depth,
             "depth": C_DEPTH * scale / depth}[kind]
    return lever * step + STEP_NOISE_REL * scale


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("family", list(sw.STACKS))
def test_stack_sweeps_of_yaw_shift_tilt_and_depth_stay_face_contacts(family, seed):
    made, c = family_sweeps(family, seed)
    kinds = np.concatenate([[kind] * len(s.param) for kind, s in made])
    bad = ~np.isin(c.contact_type_code, FACE_CODES) | ~c.colliding
    assert not bad.any(), dict(zip(*np.unique(np.char.add(kinds[bad], ": " + c.contact_type[
        bad]), return_counts=True)))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("family", list(sw.STACKS))
def test_stack_sweeps_of_yaw_shift_tilt_and_depth_move_the_point_boundedly(family, seed):
    made, c = family_sweeps(family, seed)
    start, worst = 0, {}
    for kind, s in made:
        n = len(s.param)
        ratio = sw.steps(c.point[start:start + n]) / step_bound(kind, s)
        worst[kind] = max(worst.get(kind, 0.0), ratio.max())
        start += n
    assert max(worst.values()) <= 1.0, {k: f"{v:.3g} x bound" for k, v in worst.items()}


@pytest.mark.parametrize("span", [1e-6, 0.05])
def test_cube_on_its_edge_turned_through_45_degrees_point_follows_the_edge(span):
    d, delta = 0.01, np.linspace(-span, span, 201)
    made = sw.edge_down_sweep(delta, d)
    c = solve(made.poses)
    assert (c.contact_type == "face-edge").all()
    # Edge at y = 0.2 + sqrt2 sin(delta); strips of widths d cot(phi) (+y) and d tan(phi)
    # (-y), phi = 45 deg + delta, pressure falling linearly to 0: CoP (w+ - w-) / 3 off the
    # edge, d / 3 below the plane; the edge spans x in [-0.9, 1] on A's face.
    phi = np.pi / 4 + delta
    edge_y = 0.2 + np.sqrt(2.0) * np.sin(delta)
    expected = np.column_stack([np.full_like(delta, 0.05),
                                edge_y + d * (1 / np.tan(phi) - np.tan(phi)) / 3,
                                np.full_like(delta, 1.0 - d / 3)])
    err = np.linalg.norm(c.point - expected, axis=1)
    moved, edge = np.ptp(c.point[:, 1]), np.ptp(edge_y)
    assert (err <= point_tolerance(made.poses, c.depth)).all(), (
        f"off by {err.max():.3e} m; the point moved {moved:.3e} m, the edge {edge:.3e} m")


def test_vertex_down_cube_through_the_three_face_tie_point_follows_the_vertex():
    d = 0.01
    made = sw.vertex_down_sweep(VERTEX_AXES, np.linspace(-1e-3, 1e-3, 201), d)
    poses = made.poses
    c = solve(poses)
    assert (c.contact_type == "face-vertex").all()
    off = np.linalg.norm(c.point[:, :2] - sw.lowest_corner_xy(poses), axis=1)
    bound = VERTEX_LEVER * d * np.abs(made.param) + point_tolerance(poses, c.depth)
    assert (off <= bound).all(), f"{off.max():.3e} m off the vertex"
    # Each face's footprint is a triangle, depth d at the vertex and 0 on its far side.
    np.testing.assert_allclose(c.point[:, 2], 1.0 - d / 4, atol=point_tolerance(poses, d).max())


def test_vertex_down_cube_sliding_off_an_edge_jumps_a_few_depths_at_edge_edge(
        record_property):
    d, n, yaws = 0.01, 801, (0.0, 0.3, 1.0, 2.0)
    made = sw.vertex_slide(yaws, d, n)
    c = solve(made.poses)
    jumps, change = [], []
    for k in range(len(yaws)):
        rows = slice(k * n, (k + 1) * n)
        hit = c.colliding[rows][1:] & c.colliding[rows][:-1]
        code = c.contact_type_code[rows]
        swap = (code[1:] == EDGE_EDGE) != (code[:-1] == EDGE_EDGE)
        jumps.append(sw.steps(c.point[rows])[hit] / d)
        change.append(jumps[-1][swap[hit]])
    assert all(len(j) for j in change), "no change between a face type and edge-edge"
    worst = max(j.max() for j in change)
    print(f"largest move across face <-> edge-edge: {worst:.3f} d")
    record_property("largest_move_across_edge_edge_change_in_depths", float(worst))
    assert max(j.max() for j in jumps) <= TYPE_CHANGE_JUMP_D, (
        f"largest move {max(j.max() for j in jumps):.3f} d; across the change {worst:.3f} d")


# C. Swapping A and B ---------------------------------------------------------------------------
@pytest.mark.parametrize("family", list(sw.STACKS))
def test_swap_gives_the_same_contact_where_one_face_clearly_wins(family):
    made, c = family_sweeps(family)
    tilt = SWEEP_KINDS.index("tilt") * SWEEP_COUNT * SWEEP_POINTS
    rows = np.concatenate([start + np.arange(SWEEP_POINTS // 2, SWEEP_POINTS) for start in
                           range(tilt, tilt + SWEEP_COUNT * SWEEP_POINTS, SWEEP_POINTS)])
    poses = sw.take(sw.concatenate([s for _, s in made]), rows)  # tilts past edge-face
    ab, ba = c.take(rows), solve(poses, SWAPPED)
    err = np.linalg.norm(ab.point - ba.point, axis=1)
    assert (err <= point_tolerance(poses, ab.depth)).all(), f"{err.max():.3e} m"
    np.testing.assert_allclose(ba.normal, -ab.normal, atol=NORMAL_NOISE)
    np.testing.assert_allclose(ba.depth, ab.depth, atol=DEPTH_NOISE_REL * made[0][1].scale)


@pytest.mark.parametrize("family", STACK_FAMILIES)
def test_swap_of_near_parallel_faces_moves_the_point_by_order_tilt_times_depth(family):
    made, ab, _ = stacking(family)
    rows = negligible(made) & (made.param <= 1e-6)
    ba = solve(made.poses, SWAPPED)
    theta, d, scale = made.param, made.depth, made.scale
    err = np.linalg.norm(ab.point - ba.point, axis=1)
    bound = SWAP_TIE_LEVER * theta * d + point_tolerance(made.poses, d)
    assert (err <= bound)[rows].all(), f"{(err / bound)[rows].max():.3g} x bound"
    angle = sw.angle_between(ab.normal, -ba.normal)
    assert (angle <= 2 * theta + NORMAL_NOISE)[rows].all()
    depth_gap = np.abs(ab.depth - ba.depth)
    assert (depth_gap <= theta * scale + DEPTH_NOISE_REL * scale)[rows].all()


# D. Batch against single pairs ----------------------------------------------------------------
def sweep_groups():
    """Named pose batches of every sweep above, built on demand."""
    groups = {f"stack_{f}": (lambda f=f: stacking(f)[0].poses) for f in STACK_FAMILIES}
    groups.update({f"sweeps_{f}": (lambda f=f: sw.concatenate([s for _, s in family_sweeps(
        f)[0]])) for f in sw.STACKS})
    groups["readme"] = lambda: sw.yaw_sweep(sw.C40, sw.SPREADER, (0.3, 0.1, 1.69),
                                            np.linspace(0, 0.05, 2001)).poses
    groups["vertex_slide"] = lambda: sw.vertex_slide((0.0, 1.0), 0.01, 401).poses
    groups["edge_down"] = lambda: sw.edge_down_sweep(np.linspace(-0.05, 0.05, 401), 0.01).poses
    groups["vertex_down"] = lambda: sw.vertex_down_sweep(
        VERTEX_AXES, np.linspace(-1e-3, 1e-3, 201), 0.01).poses
    return groups


@pytest.mark.parametrize("group", list(sweep_groups()))
def test_batch_equals_single_pairs_bit_for_bit(group):
    poses = sweep_groups()[group]()
    rows = np.random.default_rng(3).choice(len(poses["size_a"]), 200, replace=False)
    batch = solve(sw.take(poses, rows))
    for i, row in enumerate(rows):
        one = box_box(*(poses[key][row] for key in KEYS))
        for name in ("point", "normal", "depth", "contact_type_code"):
            assert np.array_equal(getattr(one, name)[0], getattr(batch, name)[i]), (name, row)


# E. Exactly touching features ------------------------------------------------------------------
@pytest.mark.parametrize("size_b,xy,centroid", [
    (sw.CUBE, (0.3, 0.2), (0.15, 0.1)), ((1.0, 1.0, 1.0), (0.3, 0.2), (0.3, 0.2))])
def test_touching_aligned_faces_point_is_the_overlap_area_centroid(size_b, xy, centroid):
    c = solve(sw.resting_poses(sw.CUBE, size_b, 0.0, xy))
    assert c.colliding[0] and c.depth[0] == 0.0 and c.contact_type[0] == "face-face"
    np.testing.assert_allclose(c.point[0], [*centroid, 1.0], atol=TOUCH_TOL)


@pytest.mark.parametrize("x,centroid", [(0.1, 0.05), (1.5, 0.75)])
def test_touching_edge_point_is_the_segment_centroid(x, centroid):
    poses = sw.resting_poses(sw.CUBE, sw.CUBE, 0.0, (x, 0.2), base=sw.edge_down_base())
    c = solve(poses)
    assert c.colliding[0] and c.depth[0] <= DEPTH_NOISE_REL * 2.0
    tol = TOUCH_REL * scale_of(poses)[0]  # the faces at the edge slope 1 in 1
    np.testing.assert_allclose(c.point[0], [centroid, 0.2, 1.0], atol=tol)


def test_touching_vertex_point_is_the_vertex():
    rng = np.random.default_rng(5)
    n = 64
    poses = sw.resting_poses(sw.CUBE, (1.0, 1.0, 1.0), 0.0, rng.uniform(-0.2, 0.2, (n, 2)),
                             rng.uniform(-np.pi, np.pi, n), rng.uniform(0.01, 0.3, n),
                             sw.random_axes(rng, n))
    poses = {k: np.concatenate([v, sw.resting_poses(
        sw.CUBE, sw.CUBE, 0.0, (0.1, 0.2), base=sw.vertex_down_base())[k]]) for k, v in
             poses.items()}
    c = solve(poses)
    assert c.colliding.all() and (c.depth <= DEPTH_NOISE_REL * 2.0).all()
    rise = np.abs(quaternion_to_matrix(poses["quaternion_b"])[:, 2, :])  # B's edges from it
    slope = (rise / np.sqrt(1.0 - rise**2)).min(axis=1)
    err = np.linalg.norm(c.point - np.column_stack([sw.lowest_corner_xy(poses), np.ones(n + 1)]),
                         axis=1)
    tol = TOUCH_REL * scale_of(poses) / slope
    assert (err <= tol).all(), f"{(err / tol).max():.3g} x tolerance"


@pytest.mark.parametrize("family", STACK_FAMILIES)
def test_exactly_touching_stacks_tilted_about_random_axes_touch_on_the_plane(family):
    size_a, size_b = sw.STACKS[family]
    rng = np.random.default_rng(50 + STACK_FAMILIES.index(family))
    made = sw.tilted_stacks(size_a, size_b, rng, STACK_COUNT, TILTS, depth=0.0)
    c = solve(made.poses)
    assert c.colliding[made.param == 0].all() and (c.depth <= DEPTH_NOISE_REL * made.scale).all()
    hit = c.colliding
    tol = TOUCH_REL * made.scale
    assert (np.abs(c.point[hit, 2] - 0.5 * size_a[2]) <= tol).all()
    assert (np.abs(c.point[hit, :2]) <= 0.5 * np.asarray(size_a[:2]) + tol).all()
