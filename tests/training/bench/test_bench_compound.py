"""The compound benchmark's smoke run: every figure measured, each goal stated."""
import pytest

from impactnet.training.bench.compound import measure, report, stacking_poses


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
    from impactnet.training.bench.compound_detail import measure_level, plot, report

    rows = [measure_level("castings (detail 1)", 1, None, 40, 10, 1),
            measure_level("twistlocks, 8 sides", 2, 8, 10, 5, 1)]
    for row in rows:
        for key in ("oracle_us", "oracle_one_us", "fcl_mesh_us", "fcl_convex_us", "mujoco_us"):
            assert 0 < row[key] < 1e6, key
    castings = rows[0]
    # box castings: FCL Box-Box and MuJoCo's box collider find exactly the oracle's part pairs
    assert castings["fcl_convex_same_set"] == castings["mujoco_same_set"] == 1.0
    assert castings["mujoco_depth_p99"] < 1e-9
    text = report(rows, "impactnet bench compound --quick")
    assert "| castings (detail 1) | 40 |" in text
    plot(rows, tmp_path / "cost.png")
    assert (tmp_path / "cost.png").stat().st_size > 10_000
