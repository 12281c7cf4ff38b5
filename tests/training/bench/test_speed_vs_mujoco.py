"""Speed against MuJoCo called from Python (issue #32): the timing harnesses answer what a direct
MuJoCo call answers, the ratios are ours / MuJoCo per pair or pose, the stage profile times
what it is given, and `impactnet bench speed --quick` writes its report."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.training.bench.pose_sets import stacking_set
from impactnet.training.bench.speed import ratios as rt
from impactnet.training.bench.speed import stages as st

mujoco = pytest.importorskip("mujoco")

#: Contact positions of two calls on the same geoms agree to this (m): MuJoCo's box-box is
#: deterministic, and its separation slack is 1e-13 of the half-sizes.
POSITION_TOL_M = 1e-9
SIZE_A, SIZE_B = np.array([2.0, 2.0, 2.0]), np.array([1.0, 1.5, 2.0])
#: Known poses of B (position, quaternion (w, x, y, z)) on A at the origin: resting on A's top
#: face tilted by 10 mrad (a face contact), and a corner dipped into it (a vertex contact).
KNOWN_POSES = {
    "tilted on the top face": (np.array([0.1, -0.2, 1.995]),
                               Rotation.from_rotvec([0.01, 0.0, 0.0]).as_quat(scalar_first=True)),
    "corner into the top face": (np.array([0.3, 0.2, 2.33]),
                                 Rotation.from_rotvec([0.6, 0.5, 0.2]).as_quat(scalar_first=True)),
}


def _direct(position_b, quaternion_b):
    """MuJoCo called directly, on its own model text: mj_forward, then the contacts."""
    half_a, half_b = (" ".join(map(str, 0.5 * s)) for s in (SIZE_A, SIZE_B))
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><option gravity="0 0 0"/><worldbody>'
        f'<body><freejoint/><geom type="box" size="{half_a}" margin="0" gap="0"/></body>'
        f'<body><freejoint/><geom type="box" size="{half_b}" margin="0" gap="0"/></body>'
        "</worldbody></mujoco>")
    data = mujoco.MjData(model)
    data.qpos[:] = np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, position_b, quaternion_b]
    mujoco.mj_forward(model, data)
    return [(np.array(c.pos), np.array(c.frame), float(c.dist)) for c in data.contact]


@pytest.mark.parametrize("name", KNOWN_POSES)
def test_one_pair_harness_returns_the_contacts_of_a_direct_mujoco_call(name):
    from impactnet.training.bench.speed.mujoco_calls import box_pair_call

    position_b, quaternion_b = KNOWN_POSES[name]
    call = box_pair_call(SIZE_A, SIZE_B)
    pos, frame, dist = call(np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]), position_b,
                            quaternion_b)
    expected = _direct(position_b, quaternion_b)
    assert pos.shape == (len(expected), 3) and frame.shape == (len(expected), 9)
    assert len(expected) >= (2 if name.startswith("tilted") else 1)
    for k, (p, f, d) in enumerate(expected):
        assert np.abs(pos[k] - p).max() <= POSITION_TOL_M
        assert np.abs(frame[k] - f).max() <= 1e-12 and abs(dist[k] - d) <= POSITION_TOL_M


def test_explicit_pair_model_answers_each_pair_as_a_two_box_model():
    from impactnet.training.bench.speed.mujoco_calls import ExplicitPairs, box_pair_call

    poses = stacking_set(60, seed=4)  # every family: sizes change from pair to pair
    model = ExplicitPairs(pairs=25)
    blocks = model.blocks(poses.args())
    assert len(blocks) == 2  # the rest of 10 pairs is left out
    touching = 0
    for b, block in enumerate(blocks):
        model.place(*block)
        model.kinematics()
        model.collision()
        pos, frame, dist, pair = model.contacts()
        for k in range(model.pairs):
            row = 25 * b + k
            call = box_pair_call(poses.size_a[row], poses.size_b[row])
            p, f, d = call(poses.position_a[row], poses.quaternion_a[row],
                           poses.position_b[row], poses.quaternion_b[row])
            assert len(d) == (pair == k).sum()  # 0 for a few tilted containers, as box_box
            if len(d):
                assert np.abs(pos[pair == k] - p).max() <= POSITION_TOL_M
                assert np.abs(dist[pair == k] - d).max() <= POSITION_TOL_M
            touching += len(d) > 0
    assert touching >= 45
    kinematics, collision, contacts = model.pass_seconds(blocks)
    assert kinematics > 0 and collision > 0 and contacts >= 50


def test_compound_harness_finds_the_part_pairs_of_the_reference_loop():
    from impactnet.models.compound import crane_bodies as cb
    from impactnet.training.bench.compound.detail_one import stacking_poses
    from impactnet.training.bench.compound.mujoco_model import pairs_of
    from impactnet.training.bench.compound.references import mujoco_single
    from impactnet.training.bench.speed.mujoco_calls import compound_call

    parts = cb.container("40ft", 2)
    position, quaternion = stacking_poses(3, seed=2)
    _, expected = mujoco_single(parts, parts, position, quaternion)
    call = compound_call(parts, parts)
    for k in range(3):
        pos, frame, dist, geom = call(np.zeros(3), np.array([1.0, 0, 0, 0]), position[k],
                                      quaternion[k])
        found = pairs_of(frame, dist, geom, len(parts))
        assert found.keys() == expected[k].keys() and len(found) >= 4
        for key, (depth, normal) in found.items():
            assert abs(depth - expected[k][key][0]) <= POSITION_TOL_M
            assert np.abs(normal - expected[k][key][1]).max() <= 1e-9


def test_ratios_are_ours_over_mujoco_and_goals_are_upper_bounds():
    assert rt.ratio(6.0, 4.0) == 1.5
    assert rt.ratio(None, 4.0) is None and rt.ratio(1.0, 0.0) is None
    assert rt.ratio(float("nan"), 1.0) is None
    assert rt.verdict(1.5, rt.GOAL_BOX_ONE) == "met"
    assert rt.verdict(1.5000001, rt.GOAL_BOX_ONE) == "NOT met"
    assert rt.verdict(None, 1.0) == "not measured"
    assert rt.times(2.25) == "2.25x" and rt.times(1234.5) == "1,234x"
    assert rt.goal_line("N = 1", 6.0, 4.0, 1.5) == \
        "N = 1: 6 µs / 4 µs = 1.5x (goal <= 1.5x): met"
    assert rt.goal_line("batch", 3.0, 1.0, 1.0).endswith("= 3x (goal <= 1x): NOT met")
    assert rt.goal_cell(None, 2.0) == rt.DASH


def test_box_pair_figures_are_medians_per_pair_and_their_ratios():
    from impactnet.training.bench.speed import box_pairs
    from impactnet.training.bench.speed.mujoco_calls import ExplicitPairs

    poses = stacking_set(50, seed=5)
    many = box_pairs.batch(poses, 45, repeats=2, model=ExplicitPairs(pairs=20))
    assert many["n"] == 45 and many["mujoco_pairs"] == 40  # whole blocks only
    assert many["ratio"] == many["ours_us"] / many["mujoco_us"]
    assert many["ratio_one_thread"] == many["ours_one_thread_us"] / many["mujoco_us"]
    assert 1.0 <= many["mujoco_contacts_per_pair"] <= 8.0
    one = box_pairs.one_pair(poses, calls=12, warmup=3, rounds=2)
    assert one["calls"] == 12 and one["ratio"] == one["ours_us"] / one["mujoco_us"]
    lines = "\n".join(box_pairs.tables([{"pose_set": "stacking", "description": "",
                                         "one": one, "batch": many}]))
    assert f"goal <= {rt.GOAL_BOX_ONE:g}x" in lines and f"goal <= {rt.GOAL_BOX_BATCH:g}x" in lines


def test_stage_profile_sums_stages_and_leaves_the_rest_to_the_whole(monkeypatch):
    # a fake clock: each "stage" returns the seconds it stands for
    monkeypatch.setattr(st, "call_times", lambda calls, warmup: [fn() for fn, _ in calls])
    stages = {"broadphase": lambda: 2e-3, st.PART_OF + "its part": lambda: 1e-3,
              "summary": lambda: 1e-3}
    out = st.profile("solver", "pose", 10, lambda: (stages, lambda: 5e-3), repeats=3)
    assert out["stages"]["broadphase"] == pytest.approx(200.0)  # µs per pose
    assert out["stages"][st.REST] == pytest.approx(200.0)  # 5 - 2 - 1 ms: the part not summed
    assert out["whole_us"] == pytest.approx(500.0)
    text = st.table([out])
    assert "| solver (10 poses) | broadphase | 200 | 40 % |" in text


def test_a_stage_source_without_its_functions_gives_a_note_not_a_failure():
    def gone():
        raise AttributeError("module 'oracle' has no attribute '_narrowphase'")

    def changed():
        def stage():
            raise TypeError("_hidden() takes 6 positional arguments but 7 were given")
        return {"covered-surface filter": stage}, None

    for build in (gone, changed):
        out = st.profile("compound_answer", "pose", 5, build, repeats=1)
        assert "stage_sources.py" in out["note"] and "stages" not in out
        assert out["note"] in st.table([out])


def test_todays_stage_sources_run_every_stage():
    from impactnet.models.compound import crane_bodies as cb
    from impactnet.training.bench.compound.detail_one import stacking_poses
    from impactnet.training.bench.speed.stage_sources import box_stages, compound_stages

    stages, whole = box_stages(stacking_set(40, seed=1).args())
    assert len(stages) >= 2  # NumPy solver: checks, frame, axes...; compiled: fewer, fused
    parts = cb.container("40ft", 2)
    position, quaternion = stacking_poses(4, seed=1)
    found, answer = compound_stages(parts, np.zeros(3), np.array([1.0, 0, 0, 0]), parts,
                                    position, quaternion)
    assert list(found) == ["input rows and checks", "broadphase",
                           "box parts (+ filter, summary)", "convex parts (+ filter, summary)",
                           st.PART_OF + "summary"]
    for stage in [*stages.values(), whole, *found.values()]:
        stage()
    assert len(answer()) == 4


def test_compound_level_gets_n1_and_batch_ratios_against_mujoco_from_python():
    from impactnet.models.compound import crane_bodies as cb
    from impactnet.training.bench.compound.detail_one import stacking_poses
    from impactnet.training.bench.speed.compound_speed import goal_lines, one_pose, table

    parts = cb.container("40ft", 1)
    position, quaternion = stacking_poses(8, seed=3)
    row = one_pose(parts, parts, position, quaternion, calls=8, batch_us=50.0)
    assert row["oracle_one_us"] > 0 and row["mujoco_py_us"] > 0 and row["timed_poses"] == 6
    assert row["one_vs_mujoco"] == row["oracle_one_us"] / row["mujoco_py_us"]
    assert row["batch_vs_mujoco"] == 50.0 / row["mujoco_py_us"]
    row |= {"level": "castings (detail 1)", "poses": 8, "oracle_us": 50.0}
    text = "\n".join(table([row]) + goal_lines([row]))
    assert f"goal <= {rt.GOAL_COMPOUND_ONE:g}x" in text
    assert f"batch of 8 per pose: 50 µs / {rt.figure(row['mujoco_py_us'])} µs" in text


def test_impactnet_bench_speed_quick_writes_its_report(tmp_path, capsys):
    from impactnet.training.bench.cli import main

    assert main(["speed", "--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "speed.md").read_text(encoding="utf-8")
    results = json.loads((tmp_path / "speed.json").read_text(encoding="utf-8"))
    assert "## Speed against MuJoCo called from Python" in text and "### Stage profile" in text
    assert [f["pose_set"] for f in results["speed"]["families"]] == ["scene", "stacking"]
    for family in results["speed"]["families"]:
        assert family["batch"]["mujoco_pairs"] == family["batch"]["n"] == 10_000
        assert family["one"]["ratio"] == pytest.approx(
            family["one"]["ours_us"] / family["one"]["mujoco_us"])
    assert {p["solver"] for p in results["speed"]["profiles"]} >= {"box_box"}
    assert "box_box / MuJoCo" in capsys.readouterr().out
