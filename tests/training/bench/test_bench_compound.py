"""The compound benchmark's smoke runs: every figure measured, each goal stated, the report, the
plot and the `impactnet bench compound` wiring."""
import pytest

from impactnet.training.bench.compound import detail as compound_detail
from impactnet.training.bench.compound.detail_one import measure, report, stacking_poses

#: Small levels (label, detail, body B, oracle poses, reference poses) for the smoke runs.
TINY_LEVELS = (("castings (detail 1)", 1, None, 40, 10),
               ("apertures (detail 2)", 2, None, 10, 5),
               ("cell guide", 2, compound_detail.GUIDE, 6, 3))
#: A detail-1 goal run of a few poses (poses, repeats, N = 1 calls, FCL poses).
TINY_GOALS = {True: (200, 1, 5, 3), False: (200, 1, 5, 3)}


def test_stacking_poses_are_seeded_and_unit():
    position, quaternion = stacking_poses(50, seed=3)
    again, _ = stacking_poses(50, seed=3)
    assert (position == again).all()
    assert abs((quaternion ** 2).sum(axis=1) - 1).max() < 1e-12


def test_quick_measurement_reports_every_goal():
    figures = measure(poses=200, repeats=1, singles=10, fcl_poses=3)
    assert figures["batch_us_per_pose"] > 0 and figures["one_us"] > 0
    assert figures["contacts_per_pose"] >= 1  # stacking touches on castings
    text = report(figures)
    assert text.count("goal") == (3 if figures["fcl_us_per_pose"] else 2)


def test_cost_against_detail_measures_every_reference_on_the_same_poses(tmp_path):
    pytest.importorskip("fcl")
    pytest.importorskip("mujoco")
    from impactnet.training.bench.compound.references import REFERENCES
    from impactnet.training.bench.compound.report import plot
    from impactnet.training.bench.compound.report import report as page

    rows = [compound_detail.measure_level("castings (detail 1)", 1, None, 40, 10, 1),
            compound_detail.measure_level("twistlocks, 8 sides", 2, 8, 10, 5, 1),
            compound_detail.measure_level("cell guide", 2, compound_detail.GUIDE, 8, 4, 1)]
    for row in rows:
        for key in ["oracle_us", "oracle_one_us", "mujoco_py_us"] + [
                f"{k}_us" for k, _, _ in REFERENCES]:
            assert 0 < row[key] < 1e6, key
        assert row["ref_poses"] <= row["poses"]
        assert row["one_vs_mujoco"] == row["oracle_one_us"] / row["mujoco_py_us"]
        assert row["batch_vs_mujoco"] == row["oracle_us"] / row["mujoco_py_us"]
    assert rows[2]["contacts_per_pose"] >= 1  # the container touches the guide
    castings = rows[0]
    # box castings: FCL Box-Box and MuJoCo's box collider find exactly the oracle's part pairs
    for key in ("fcl_convex", "mujoco", "mujoco_epa"):
        errors = castings[f"{key}_errors"]
        assert errors["same_set"] == errors["rows_ok"] == 1.0, key
        assert errors["depth_max"] < 1e-9, key
    # twistlock heads as mesh geoms: MuJoCo's single EPA contact agrees on every pose
    assert rows[1]["mujoco_epa_errors"]["rows_ok"] == 1.0
    text = page(rows, measure(200, 1, 5, 3), "impactnet bench compound --quick", 1.0)
    assert "| castings (detail 1) | 40 |" in text and "| cell guide | 8 |" in text
    assert all(label in text for _, label, _ in REFERENCES)
    assert "## Against MuJoCo called from Python (issue #32)" in text
    assert "N = 1 / MuJoCo (goal <= 2x)" in text and "batch / MuJoCo (goal <= 1x)" in text
    assert text.count("(goal <= 2x): ") == text.count("(goal <= 1x): ") == 3
    assert "goal <= 15" in text and "goal <= 150" in text and "goal >= 5x" in text
    plot(rows, tmp_path / "cost.png")
    assert (tmp_path / "cost.png").stat().st_size > 10_000


def test_detail_two_goal_against_fcl_mesh_is_stated_met_or_not():
    from impactnet.training.bench.compound.report import GOAL_MESH_RATIO
    from impactnet.training.bench.compound.report import report as page

    level = {"level": "apertures (detail 2)", "poses": 10, "ref_poses": 5, "oracle_us": 100.0,
             "oracle_one_us": 1000.0, "contacts_per_pose": 20.0, "fcl_mesh_us": 2000.0}
    goals = {"poses": 10, "contacts_per_pose": 2.0, "batch_us_per_pose": 10.0, "one_us": 100.0,
             "fcl_us_per_pose": None}
    assert f"20x faster (goal >= {GOAL_MESH_RATIO:g}x): NOT met" in page([level], goals, "c", 1)
    level["fcl_mesh_us"] = 6000.0
    assert f"60x faster (goal >= {GOAL_MESH_RATIO:g}x): met" in page([level], goals, "c", 1)


def test_impactnet_bench_compound_writes_the_table_and_the_plot(tmp_path, monkeypatch, capsys):
    pytest.importorskip("fcl")
    pytest.importorskip("mujoco")
    from impactnet.training.bench.cli import main

    monkeypatch.setattr(compound_detail, "LEVELS", TINY_LEVELS)
    monkeypatch.setattr(compound_detail, "DETAIL_ONE", TINY_GOALS)
    monkeypatch.setattr(compound_detail, "QUICK_MIN", 3)
    image = tmp_path / "images" / "cost.png"
    assert main(["compound", "--quick", "--out", str(tmp_path), "--plot", str(image)]) == 0
    text = (tmp_path / "compound.md").read_text(encoding="utf-8")
    assert f"`impactnet bench compound --quick --out {tmp_path} --plot {image}`" in text
    assert "goal >= 50x" in text and "| castings (detail 1) | 4 |" in text
    assert "| cell guide | " in text and "MuJoCo from Python, per pose" in text
    assert image.stat().st_size > 10_000
    assert "apertures (detail 2): oracle" in capsys.readouterr().out
