"""The compound oracle against MuJoCo 4 (one geom per part: box geoms, mesh geoms of the hulls)
on the stacking family at detail levels 1 and 2 and on twistlock entry at detail 2: the set of
touching part pairs, each pair's normal and depth, and the body-level summary. Issue #20's
targets: the same set on >= 99.5 % of poses; normals within 1 deg and depths within 1e-6 m on
the pairs both find.

At detail 2 the reference is MuJoCo's single EPA contact per geom pair (``multiccd``
disabled; tests/models/compound/mujoco_compound.py). Measured with it on this module's families
(2,000 stacking poses, seed 21; 1,000 twistlock poses, seed 22, at each of 8, 32, 128 and 256
sides): the same part pairs on 100 % of poses; normals within 0.46 deg (stacking) and 0.55 deg
(twistlocks), where the tie rule prefers a face axis to a nearly equal edge axis; depths within
2.3e-7 m on every twistlock pair and on all but 3 of 50,877 stacking pairs (2 poses: 99.9 % of
the rows within both tolerances). On those 3 MuJoCo's depth is 1.2-1.9e-6 m short and is not
a separating translation: the two hulls still overlap along MuJoCo's own normal by more than
its depth plus 1e-6 m (for box and mesh geoms MuJoCo's EPA ignores ``ccd_tolerance`` and ends
at a repeated support vertex, ``epa`` in engine_collision_gjk.c), while the oracle's depth is
the overlap along its own normal. The tests therefore hold >= 99.5 % of the rows to both
tolerances and check that every pair outside them is such a stop.

MuJoCo's default contacts (``multiccd`` on) are not a depth reference: a clipped contact polygon
of more than four vertices is pruned to its largest quadrilateral, which may drop the deepest
vertex. Measured on the same poses: stacking depths short by up to 5.7e-5 m (79 % of rows within
the tolerances); twistlocks off by up to 1.5e-5 m either way, normals by up to 5.1 deg (74-99.5 %
of rows). The last tests pin that on stacking this is the pruning (never deeper than the oracle,
short by at most the tilt times the parts' extent), and one recorded EPA stop.
"""
from functools import cache

import numpy as np
import pytest

from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.compound.summary import CLUSTER_ANGLE_DEG, summarise
from impactnet.models.geometry.rotations import quaternion_to_matrix
from impactnet.models.metrics import angle_deg
from tests.models.compound.mujoco_compound import mujoco_part_contacts

pytest.importorskip("mujoco")

SET_TARGET, NORMAL_TOL_DEG, DEPTH_TOL_M = 0.995, 1.0, 1e-6
POSES = 300
#: Detail-2 poses per family (more for stacking: its rows hold ~25 pairs each).
DETAIL_TWO_POSES = {"stacking": 600, "twistlock": 300}
#: A pair outside the tolerances counts as MuJoCo's EPA stopping short when the hulls still
#: overlap along MuJoCo's own normal by more than its depth plus this (m) ...
EPA_SHORT_M = DEPTH_TOL_M
#: ... and the oracle's depth is the overlap along its own normal within this (m, rounding) or
#: below it (the region's depth where the incident part hangs past the reference face).
OVERLAP_ROUNDING_M = 1e-12
#: The summary's depth may differ from MuJoCo's deepest by its EPA stopping short (module
#: docstring: up to 2e-6 m measured) (m).
EPA_SLACK_M = 3 * DEPTH_TOL_M
#: Far tilt of the detail-2 families (rad): near level, log-uniform from 1e-6.
STACK_TILT, TWISTLOCK_TILT = 2e-3, 1e-3


def _stacking(kind_a, kind_b, seed):
    """B set down on A, flush with A's +x end (a 20 ft on a 40 ft stands on its end castings):
    offset up to 50 mm, tilted up to 2 mrad about a random axis, pushed 0-5 mm."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(POSES, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0.0, 2e-3, POSES)
    quaternion = np.c_[np.cos(angle / 2), np.sin(angle / 2)[:, None] * axis]
    height = (cb.CONTAINERS[kind_a][2] + cb.CONTAINERS[kind_b][2]) / 2
    end = (cb.CONTAINERS[kind_a][0] - cb.CONTAINERS[kind_b][0]) / 2  # flush with A's +x end
    position = np.c_[end + rng.uniform(-0.05, 0.05, POSES), rng.uniform(-0.05, 0.05, POSES),
                     height - rng.uniform(0, 5e-3, POSES)]
    return position, quaternion


FAMILIES = [("40ft", "40ft"), ("40ft", "20ft"), ("20ft", "20ft")]


def _compare(kind_a, kind_b):
    parts_a, parts_b = cb.container(kind_a), cb.container(kind_b)
    position, quaternion = _stacking(kind_a, kind_b, seed=len(kind_a + kind_b))
    ours = compound_contacts(parts_a, np.zeros(3), [1.0, 0, 0, 0], parts_b, position, quaternion)
    theirs = mujoco_part_contacts(parts_a, parts_b, position, quaternion)
    same_set, normals, depths = 0, [], []
    for pose in range(POSES):
        rows = ours.of_pose(pose)
        mine = {(int(a), int(b)): k for a, b, k in zip(ours.part_a[rows], ours.part_b[rows],
                                                     range(rows.start, rows.stop))}
        same_set += set(mine) == set(theirs[pose])
        for key in set(mine) & set(theirs[pose]):
            depth, normal = theirs[pose][key]
            normals.append(float(angle_deg(ours.contacts.normal[mine[key]], normal)))
            depths.append(abs(ours.contacts.depth[mine[key]] - depth))
    return same_set / POSES, np.array(normals), np.array(depths)


@pytest.mark.parametrize("kind_a,kind_b", FAMILIES)
def test_stacking_part_pairs_both_find_agree_with_mujoco_in_normal_and_depth(kind_a, kind_b):
    _, normals, depths = _compare(kind_a, kind_b)
    assert len(normals) >= POSES  # castings on castings: at least one pair per pose
    assert normals.max() <= NORMAL_TOL_DEG, normals.max()
    assert depths.max() <= DEPTH_TOL_M, depths.max()


@pytest.mark.parametrize("kind_a,kind_b", FAMILIES)
def test_stacking_touches_the_same_part_pairs_as_mujoco(kind_a, kind_b):
    share, _, _ = _compare(kind_a, kind_b)
    assert share >= SET_TARGET, share


def _level_tilts(rng, n: int, far: float) -> tuple[np.ndarray, np.ndarray]:
    """Quaternions (n, 4) tilted about random horizontal axes by log-uniform angles in
    [1e-6, far] rad, and the angles (n,)."""
    heading = rng.uniform(0.0, 2 * np.pi, n)
    tilt = np.exp(rng.uniform(np.log(1e-6), np.log(far), n))
    axis = np.c_[np.cos(heading), np.sin(heading), np.zeros(n)]
    return np.c_[np.cos(tilt / 2), np.sin(tilt / 2)[:, None] * axis], tilt


def _detail_two_stacking(n: int, seed: int):
    """A 40 ft at detail 2 set down on another: offsets up to 50 mm, a near-level tilt, the
    lowest corner of B's bottom castings pushed 0-2 mm below A's top (the ring pieces)."""
    rng = np.random.default_rng(seed)
    container = cb.container("40ft", detail=2)
    quaternion, tilt = _level_tilts(rng, n, STACK_TILT)
    corners = np.concatenate([hull_of(p).vertices for p in container
                              if p.name.startswith("casting_bottom")])
    lowest = np.einsum("nij,vj->nvi", quaternion_to_matrix(quaternion), corners)[..., 2].min(1)
    top = cb.CONTAINERS["40ft"][2] / 2
    position = np.c_[rng.uniform(-0.05, 0.05, (n, 2)), top - rng.uniform(0, 2e-3, n) - lowest]
    return container, container, position, quaternion, tilt


def _twistlock_entry(n: int, seed: int, sides: int):
    """A 40 ft spreader's heads in a detail-2 container's apertures: offsets up to 15 mm along
    and 6 mm across (beyond the 10.25 / 3.75 mm clearance), a near-level tilt, the frame's
    underside 2-30 mm above the castings (the heads' widest section in or just under the top
    plates; the frame's ends dip onto the castings where the tilt is large)."""
    rng = np.random.default_rng(seed)
    container, spreader = cb.container("40ft", detail=2), cb.spreader("40ft", sides=sides)
    quaternion, tilt = _level_tilts(rng, n, TWISTLOCK_TILT)
    lift = cb.CONTAINERS["40ft"][2] / 2 + cb.SPREADER_FRAME_HEIGHT_ASSUMED / 2
    position = np.c_[rng.uniform(-0.015, 0.015, n), rng.uniform(-0.006, 0.006, n),
                     lift + rng.uniform(0.002, 0.03, n)]
    return container, spreader, position, quaternion, tilt


@cache
def _detail_two(family: str, sides: int = 0, depth_from: str = "epa"):
    """Per pose: (oracle {pair: row}, MuJoCo {pair: (depth, normal)}), with the oracle's
    answer, the bodies, the poses and the tilts."""
    n = DETAIL_TWO_POSES[family]
    a, b, position, quaternion, tilt = (_detail_two_stacking(n, 21) if family == "stacking"
                                        else _twistlock_entry(n, 22, sides))
    ours = compound_contacts(a, np.zeros(3), [1.0, 0, 0, 0], b, position, quaternion)
    theirs = mujoco_part_contacts(a, b, position, quaternion, depth_from=depth_from)
    mine = []
    for pose in range(n):
        rows = ours.of_pose(pose)
        mine.append({(int(i), int(j)): r for i, j, r in zip(ours.part_a[rows], ours.part_b[rows],
                                                          range(rows.start, rows.stop))})
    return mine, theirs, ours, (a, b, position, quaternion, tilt)


def _overlap(x_a: np.ndarray, x_b: np.ndarray, u: np.ndarray) -> float:
    """Overlap (m) of two point sets' projections on the unit axis ``u``."""
    return min((x_a @ u).max() - (x_b @ u).min(), (x_b @ u).max() - (x_a @ u).min())


def _epa_stops_short(ours, row, key, pose, bodies, depth, normal) -> bool:
    """MuJoCo's (depth, normal) is not a separating translation while the oracle's depth is at
    most the overlap along its own normal (module docstring)."""
    a, b, position, quaternion, _ = bodies
    rotation = quaternion_to_matrix(quaternion[pose][None])[0]
    x_a = hull_of(a[key[0]]).vertices
    x_b = hull_of(b[key[1]]).vertices @ rotation.T + position[pose]
    mine = ours.contacts
    return (_overlap(x_a, x_b, normal) > depth + EPA_SHORT_M and mine.depth[row]
            <= _overlap(x_a, x_b, mine.normal[row]) + OVERLAP_ROUNDING_M)


@pytest.mark.parametrize("family,sides", [("stacking", 0), ("twistlock", 8),
                                          ("twistlock", 32), ("twistlock", 128)])
def test_detail_two_agrees_with_mujoco_mesh_geoms_on_the_rows(family, sides):
    mine, theirs, ours, bodies = _detail_two(family, sides)
    same = agree = compared = 0
    for pose, (pairs, reference) in enumerate(zip(mine, theirs)):
        same += set(pairs) == set(reference)
        good = set(pairs) == set(reference)
        for key in set(pairs) & set(reference):
            depth, normal = reference[key]
            row, compared = pairs[key], compared + 1
            assert angle_deg(ours.contacts.normal[row], normal) <= NORMAL_TOL_DEG, (pose, key)
            if abs(ours.contacts.depth[row] - depth) > DEPTH_TOL_M:
                good = False
                assert _epa_stops_short(ours, row, key, pose, bodies, depth, normal), (pose, key)
        agree += good
    assert compared >= 3 * len(mine)  # several ring pieces (or frame, heads) per pose
    assert same >= SET_TARGET * len(mine), same
    assert agree >= SET_TARGET * len(mine), agree


@pytest.mark.parametrize("sides", [8, 128])
def test_twistlock_heads_touch_ring_pieces_in_most_entry_poses(sides):
    mine, _, _, (_, spreader, *_) = _detail_two("twistlock", sides)
    with_head = sum(any(spreader[j].name.startswith("head_") for _, j in pairs) for pairs in mine)
    assert with_head >= 0.5 * len(mine), with_head  # the heads, not only the frame, compared


def test_mujoco_default_multiccd_depth_falls_short_by_the_pruned_polygon_vertices():
    """With ``multiccd`` on, a pair's deepest MuJoCo contact is a vertex of the clipped contact
    polygon pruned to four: never deeper than the oracle, short by at most the tilt times the
    two parts' largest extent, and short beyond the tolerance on many pairs (why the tests use
    the EPA contact)."""
    mine, theirs, ours, (a, b, _, _, tilt) = _detail_two("stacking", depth_from="multiccd")
    short = []
    for pose, (pairs, reference) in enumerate(zip(mine, theirs)):
        for key in set(pairs) & set(reference):
            gap = ours.contacts.depth[pairs[key]] - reference[key][0]
            reach = max(np.ptp(hull_of(a[key[0]]).vertices, axis=0).max(),
                        np.ptp(hull_of(b[key[1]]).vertices, axis=0).max())
            assert -DEPTH_TOL_M <= gap <= np.sin(tilt[pose]) * reach + DEPTH_TOL_M, (pose, key)
            short.append(gap > DEPTH_TOL_M)
    assert 0.01 < np.mean(short) < 0.5, np.mean(short)


def test_mujoco_epa_stops_short_of_a_separating_translation_where_depths_differ():
    """A recorded stacking pose (seed 21, pose 154 of 2,000) where MuJoCo's EPA depth is 1.9e-6 m
    below the oracle's: the hulls still overlap along MuJoCo's own normal by more than its depth
    plus the tolerance, and the oracle's depth is the overlap along its normal. (Should a later
    MuJoCo agree here, update the measured figures in the module docstring.)"""
    a, b, position, quaternion, tilt = _detail_two_stacking(2000, 21)
    bodies = (a, b, position[154:155], quaternion[154:155], tilt[154:155])
    ours = compound_contacts(a, np.zeros(3), [1.0, 0, 0, 0], b, bodies[2], bodies[3])
    reference = mujoco_part_contacts(a, b, bodies[2], bodies[3])[0]
    pairs = {(int(i), int(j)): r for r, (i, j) in enumerate(zip(ours.part_a, ours.part_b))}
    assert set(pairs) == set(reference)
    differ = [key for key in pairs if abs(ours.contacts.depth[pairs[key]] - reference[key][0])
              > DEPTH_TOL_M]
    assert differ, "MuJoCo now agrees on the recorded pose"
    for key in differ:
        assert _epa_stops_short(ours, pairs[key], key, 0, bodies, *reference[key]), key


def _mujoco_summary(reference: dict, weights: dict) -> tuple[float, np.ndarray, float]:
    """docs/design.md's summary rule on MuJoCo's part pairs {pair: (depth, normal)}: the deepest
    depth, and the normals within CLUSTER_ANGLE_DEG of the deepest one's averaged with the
    oracle's int d dA of the same pair (``weights``; MuJoCo gives no area, a pair the oracle
    lacks weighs 0); also the depth of the deepest pair pushing the other way (0: none)."""
    keys = list(reference)
    depths = np.array([reference[k][0] for k in keys])
    normals = np.array([reference[k][1] for k in keys])
    deepest = int(np.argmax(depths))
    cluster = angle_deg(normals, normals[deepest]) <= CLUSTER_ANGLE_DEG
    weight = np.array([weights.get(k, 0.0) for k in keys]) * cluster
    if weight.sum() <= 0.0:  # edge-edge only: equal weights, as the oracle's rule
        weight = cluster.astype(float)
    mean = (weight[:, None] * normals).sum(axis=0)
    rival = depths[~cluster].max() if (~cluster).any() else 0.0
    return float(depths[deepest]), mean / np.linalg.norm(mean), float(rival)


@pytest.mark.parametrize("family,sides", [("stacking", 0), ("twistlock", 32)])
def test_the_body_summary_agrees_with_the_rule_applied_to_mujoco_contacts(family, sides):
    """The summary's depth is MuJoCo's deepest pair's and its normal MuJoCo's cluster's (with
    the oracle's weights) on every pose where both touch. Where two opposing clusters are as
    deep within the depth tolerance the summary may follow either side (docs/design.md: it flips
    where their depths swap): the normal is checked against the side the oracle chose."""
    mine, theirs, ours, _ = _detail_two(family, sides)
    summary = summarise(ours)
    compared = tied = 0
    for pose, reference in enumerate(theirs):
        if not reference or not mine[pose]:
            assert not reference and not mine[pose], pose
            continue
        weights = {k: ours.contacts.pressure[row] for k, row in mine[pose].items()}
        depth, normal, rival = _mujoco_summary(reference, weights)
        assert abs(summary.depth[pose] - depth) <= EPA_SLACK_M, pose
        if depth - rival <= DEPTH_TOL_M:  # a tie of opposing sides
            tied += 1
            normal = normal if angle_deg(summary.normal[pose], normal) <= 90 else -normal
        assert angle_deg(summary.normal[pose], normal) <= NORMAL_TOL_DEG, pose
        compared += 1
    assert compared >= 0.5 * len(theirs) and tied <= 0.05 * compared, (compared, tied)
