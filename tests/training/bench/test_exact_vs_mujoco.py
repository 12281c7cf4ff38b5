"""Exact solver against MuJoCo's box-box collider and the grid centre of pressure.

Issue #11 items 3-4 and #18 item 2. Reference of each row
(:mod:`impactnet.training.bench.accuracy.vs_mujoco`): MuJoCo's normal; as point, the centre of
pressure on the face best aligned with MuJoCo's normal where that normal lies within 1 deg of a face
normal, else MuJoCo's edge-edge point. A row is within the targets when our normal is within 1 deg
of MuJoCo's and our point within 2 % of the pair's shortest edge (the cube edge; 2.438 m for the
containers) of the reference point.

Sets: (a) stacking, B on A's top face, per tilt 0 and 1e-12 .. 1e-2 rad, for 2 m cubes, 20 ft on 40
ft and 40 ft on 40 ft containers; (b) uniform first contacts of the quay-crane scene's pairs; (c)
edge-on-edge contacts, crossed at 90 deg and skewed (1-90 deg). Every row outside the targets must
fall in an explained class (:func:`tests.training.bench.mujoco_reference.disagreement_classes`).
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.box.exact import box_box
from impactnet.models.geometry.approach import touching_distance
from impactnet.models.scenes import load_scene
from impactnet.training.bench import contact_sets as cs
from impactnet.training.bench.accuracy import vs_mujoco as vm
from impactnet.training.bench.pose_sets import scene_poses
from tests.models.box.fcl_reference import fcl_box_box
from tests.training.bench.mujoco_reference import (
    AGREE,
    DEPTH_ATOL_REL,
    SAME_AXIS_DEG,
    UNEXPLAINED,
    axis_change_bound,
    deepest_vertex_inside,
    depth_excess_explained,
    disagreement_classes,
    mujoco_box_box,
    overlap_along,
    pose_args,
)

SEED = 20261123
#: Targets, as shares of the rows where MuJoCo finds a contact (issue #11 / #18).
STACKING_TARGET, EDGE_TARGET, SCENE_TARGET = 0.995, 0.995, 0.99
#: Rows per case: one row is 0.25 % of 400, so a 99.5 % target allows one or two misses.
STACKING_ROWS, EDGE_ROWS, SCENE_ROWS = 400, 400, 4000
#: Stacking sets where some poses do not touch are topped up by this factor over the missing
#: share, so that about STACKING_ROWS rows or more are in contact.
TOP_UP = 1.2
#: Centre-of-pressure grid per stacking pair (cells, lattice points): its worst error stays
#: below ~0.15 % of the shortest edge (cop_reference's table; 40 ft footprints are 5 edges long).
STACKING_GRID = {"cube": (32, 21), "20ft on 40ft": (64, 21), "40ft on 40ft": (64, 55)}
#: Tilts in the quick run for the containers (the cube runs them all; the rest is slow).
QUICK_CONTAINER_TILTS = (0.0, 1e-9, 1e-6, 1e-3, 1e-2)
#: python-fcl and MuJoCo agree on an edge-edge contact to this fraction of the scale (both
#: compute the closest points of two segments in float64).
FCL_AGREEMENT_REL = 1e-9


def _case(args, grid=(vm.COP_GRID, vm.COP_REFINE)):
    ours = box_box(*args)
    reference = vm.mujoco_reference(args, *grid)
    errors = vm.mujoco_row_errors(ours.point, ours.normal, ours.colliding, reference)
    return {"args": args, "ours": ours, "ref": reference, "errors": errors,
            "classes": disagreement_classes(args, ours, reference, errors)}


def _stacking_params():
    params = []
    for tilt in cs.STACKING_TILTS:
        params.append(pytest.param(("cube", tilt), id=f"cube-tilt{tilt:g}"))
        for family in ("20ft on 40ft", "40ft on 40ft"):
            marks = () if tilt in QUICK_CONTAINER_TILTS else (pytest.mark.slow,)
            params.append(pytest.param((family, tilt), marks=marks,
                                       id=f"{family.replace(' ', '_')}-tilt{tilt:g}"))
    return params


def _stacking_args(family: str, tilt: float, seed: int) -> tuple:
    """At least ~STACKING_ROWS poses in contact: where B's deepest corner hangs over A's edge
    the boxes do not touch (a third of the 40 ft rows at 1e-2 rad), so those sets get more."""
    size_a, size_b = cs.STACKING_FAMILIES[family]
    poses = cs.stacking_poses(STACKING_ROWS, size_a, size_b, tilt, seed)
    share = mujoco_box_box(*pose_args(poses)).colliding.mean()
    if share < 1.0:
        extra = int(np.ceil(STACKING_ROWS * TOP_UP * (1.0 - share) / max(share, 0.05)))
        more = cs.stacking_poses(extra, size_a, size_b, tilt, seed + 1)
        poses = {key: np.concatenate([poses[key], more[key]]) for key in poses}
    return pose_args(poses)


@pytest.fixture(scope="module", params=_stacking_params())
def stacking(request):
    family, tilt = request.param
    seed = SEED + 2 * cs.STACKING_TILTS.index(tilt) + 100 * list(cs.STACKING_FAMILIES).index(
        family)
    return _case(_stacking_args(family, tilt, seed), STACKING_GRID[family])


@pytest.fixture(scope="module")
def scene_contacts():
    poses = scene_poses(load_scene("quay_crane"), SCENE_ROWS, SEED)
    return _case(poses.args())


@pytest.fixture(scope="module", params=["crossed", "skewed"])
def edge_on_edge(request):
    crossing = np.pi / 2 if request.param == "crossed" else None
    parts = [cs.edge_edge_poses(EDGE_ROWS // 2, *cs.STACKING_FAMILIES[family], SEED + k,
                                crossing=crossing)
             for k, family in enumerate(("cube", "20ft on 40ft"))]
    poses = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    case = _case(pose_args(poses))
    case["poses"] = poses
    return case


def _report(case) -> str:
    """The classes of the rows outside the targets, and the worst rows, for a failure."""
    counted = case["errors"]["counted"]
    outside = counted & ~case["errors"]["within"]
    labels, counts = np.unique(case["classes"][outside], return_counts=True)
    worst = np.flatnonzero(outside)[:5]
    return (f"{outside.sum()} of {counted.sum()} outside: {dict(zip(labels, counts))}; rows "
            f"{worst.tolist()}: normal {case['errors']['normal_deg'][worst].round(4).tolist()} "
            f"deg, point {case['errors']['point_pct'][worst].round(3).tolist()} %, ours "
            f"{case['ours'].contact_type[worst].tolist()}")


def _share_within(case) -> float:
    counted = case["errors"]["counted"]
    return float(case["errors"]["within"][counted].mean())


# ------------------------------------------------------------------ the reference itself


def test_mujoco_normal_points_from_a_to_b_and_depth_is_positive():
    for offset, normal in (([0.1, 0.2, 1.99], [0, 0, 1]), ([0.1, 0.2, -1.99], [0, 0, -1]),
                           ([1.99, 0.3, 0.0], [1, 0, 0])):
        got = mujoco_box_box([2, 2, 2], [0, 0, 0], [1, 0, 0, 0], [2, 2, 2], offset,
                             [1, 0, 0, 0])
        assert got.count[0] == 4
        np.testing.assert_allclose(got.normal[0], normal, atol=1e-15)
        np.testing.assert_allclose(got.depths[0, :4], 0.01, rtol=1e-12)
        np.testing.assert_allclose(got.points[0, :4] @ np.asarray(normal, float), 0.995,
                                   rtol=1e-12)  # mid-surface: half the depth below the face


def test_mujoco_returns_the_whole_clipped_face_of_a_yawed_stack():
    yaw = np.radians(45.0)
    got = mujoco_box_box([2, 2, 2], [0, 0, 0], [1, 0, 0, 0], [2, 2, 2], [0, 0, 1.99],
                         [np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)])
    assert got.count[0] == 8  # the octagon, not a culled subset of 4
    np.testing.assert_allclose(got.point[0], [0, 0, 0.995], atol=1e-12)


def test_mujoco_prefers_a_face_within_five_percent_of_an_edge_axis():
    """FCL's analytic example (tests/models/box/fcl_reference.py): the edge axis is exact, MuJoCo
    answers B's face 5 deg away, 3.6 % deeper; ours is the shallower edge answer."""
    rotation = Rotation.from_euler("z", 45, degrees=True) * Rotation.from_euler("y", 5,
                                                                                 degrees=True)
    direction = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    touch = touching_distance([[2.0, 2, 2]], [[2.0, 2, 2]], rotation.as_matrix()[None],
                              direction[None])[0]
    args = pose_args({"size_a": [[2.0, 2, 2]], "position_a": [[0.0, 0, 0]],
                      "quaternion_a": [[1.0, 0, 0, 0]], "size_b": [[2.0, 2, 2]],
                      "position_b": [(touch - 0.2) * direction],
                      "quaternion_b": [rotation.as_quat(scalar_first=True)]})
    case = _case(args)
    assert case["ours"].contact_type[0] == "edge-edge"
    assert case["classes"][0] == "MuJoCo prefers a face"
    assert overlap_along(case["ref"].mujoco.normal, args)[0] > case["ours"].depth[0]


def test_mujoco_and_fcl_agree_on_edge_on_edge_contacts(edge_on_edge):
    ref, args = edge_on_edge["ref"], edge_on_edge["args"]
    fcl = fcl_box_box(*args)
    scale = ref.scale
    assert (ref.mujoco.count == 1).all()
    np.testing.assert_allclose(ref.mujoco.normal, edge_on_edge["poses"]["normal"], atol=1e-12)
    np.testing.assert_allclose(ref.mujoco.depth, edge_on_edge["poses"]["push_depth"],
                               atol=(DEPTH_ATOL_REL * scale).max())
    assert (vm.angle_deg(fcl.normal, ref.mujoco.normal) <= SAME_AXIS_DEG).all()
    gap = np.linalg.norm(fcl.point - ref.mujoco.point, axis=1) / scale
    assert gap.max() <= FCL_AGREEMENT_REL


# ------------------------------------------------------------------ (a) stacking


def test_stacking_matches_mujoco_and_the_centre_of_pressure(stacking):
    assert _share_within(stacking) >= STACKING_TARGET, _report(stacking)


def test_stacking_disagreements_are_explained(stacking):
    assert not (stacking["classes"] == UNEXPLAINED).any(), _report(stacking)


def test_mujoco_prefers_a_face_over_an_edge_pair_leaning_on_a_deeper_face():
    """20 ft on 40 ft at 1e-2 rad (formerly unexplained): A's top edge and B's bottom edge
    cross, 4.6 % shallower than A's top face and 0.76 deg from its normal, outside the tie
    band; the pair leans 0.54 deg on B's bottom face, but that face's overlap is 3x deeper, so
    rule 1 (which asks only the least-overlap face) keeps the edge pair. MuJoCo answers A's
    face by its 5 % preference."""
    args = pose_args({
        "size_a": [[12.192, 2.438, 2.591]], "position_a": [[0.0, 0.0, 0.0]],
        "quaternion_a": [[1.0, 0.0, 0.0, 0.0]], "size_b": [[6.058, 2.438, 2.591]],
        "position_b": [[2.04878804, 0.16516273, 2.60214987]],
        "quaternion_b": [[0.91167468, 0.0017371, -0.00468853, 0.41088231]]})
    case = _case(args, STACKING_GRID["20ft on 40ft"])
    ours = case["ours"]
    assert ours.contact_type[0] == "edge-edge"
    assert case["classes"][0] == "MuJoCo prefers a face"
    along_face = overlap_along(case["ref"].mujoco.normal, args)[0]
    assert ours.depth[0] < along_face < 1.05 * ours.depth[0]


def test_stacking_contact_flags_agree_with_mujoco(stacking):
    """B's deepest corner may hang over A's edge with the rest above A's face: no contact."""
    differ = stacking["ours"].colliding != stacking["ref"].colliding
    assert (stacking["classes"][differ] != UNEXPLAINED).all(), np.flatnonzero(differ)[:5]


def _check_depths(case):
    """Depth against MuJoCo: its deepest contact never exceeds the overlap along its normal;
    where both pick the same axis, our depth is that overlap, and so is MuJoCo's deepest
    contact, unless the incident box's deepest vertex hangs over the reference face's edge:
    then both report the footprint's deepest point (ours over every front face, at least
    MuJoCo's over the clipped incident face) below the overlap; elsewhere ours is the
    shallower, or deeper only by what the tie rule's face preference allows
    (:func:`tests.training.bench.mujoco_reference.depth_excess_explained`)."""
    ours, ref, args = case["ours"], case["ref"], case["args"]
    mj = ref.mujoco
    rows = mj.colliding & ours.colliding
    along = overlap_along(np.where(rows[:, None], mj.normal, [[0.0, 0, 1]]), args)
    atol = DEPTH_ATOL_REL * ref.scale + 1e-300
    assert (mj.depth[rows] <= along[rows] + atol[rows]).all()
    same = rows & (vm.angle_deg(ours.normal, mj.normal) <= SAME_AXIS_DEG)
    slack = atol + axis_change_bound(args, ours.normal, mj.normal)  # two faces 1e-12 apart
    inside = same & ref.face & deepest_vertex_inside(args, mj.normal)
    np.testing.assert_array_less(np.abs(ours.depth - along)[inside], slack[inside])
    np.testing.assert_array_less(np.abs(mj.depth - along)[inside], atol[inside])
    # the deepest vertex hangs beyond the face: both report the footprint's deepest point,
    # shallower than the overlap (ours over every front face, MuJoCo's over the clipped face)
    hanging = same & ~inside
    np.testing.assert_array_less((ours.depth - along)[hanging], slack[hanging])
    np.testing.assert_array_less((mj.depth - ours.depth)[hanging], slack[hanging])
    explained = depth_excess_explained(args, ours, ref)
    assert explained.all(), np.flatnonzero(~explained)[:5]


def test_stacking_depth_agrees_with_mujoco(stacking):
    _check_depths(stacking)


# ------------------------------------------------------------------ (b) scene first contacts


def test_scene_first_contacts_match_mujoco(scene_contacts):
    assert _share_within(scene_contacts) >= SCENE_TARGET, _report(scene_contacts)


def test_scene_first_contact_disagreements_are_explained(scene_contacts):
    assert not (scene_contacts["classes"] == UNEXPLAINED).any(), _report(scene_contacts)


def test_scene_first_contact_depths_agree_with_mujoco(scene_contacts):
    _check_depths(scene_contacts)


# ------------------------------------------------------------------ (c) edge on edge


def test_edge_on_edge_matches_mujoco(edge_on_edge):
    assert _share_within(edge_on_edge) >= EDGE_TARGET, _report(edge_on_edge)


def test_edge_on_edge_disagreements_are_explained(edge_on_edge):
    assert not (edge_on_edge["classes"] == UNEXPLAINED).any(), _report(edge_on_edge)


def test_edge_on_edge_depth_is_the_push(edge_on_edge):
    ours, poses = edge_on_edge["ours"], edge_on_edge["poses"]
    agree = edge_on_edge["classes"] == AGREE
    np.testing.assert_allclose(ours.depth[agree], poses["push_depth"][agree],
                               atol=(DEPTH_ATOL_REL * edge_on_edge["ref"].scale).max())
    _check_depths(edge_on_edge)
