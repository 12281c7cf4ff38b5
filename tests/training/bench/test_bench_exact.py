"""`impactnet bench exact`: the speed budget's goals and the baseline comparison."""
from pathlib import Path

import numpy as np

from impactnet.models.geometry.poses import first_contact_poses
from impactnet.training.bench.exact.baseline import compare_single_pair
from impactnet.training.bench.exact.vs_fcl import GOAL_FCL_RATIO_1E5, Row, goals

REPO = Path(__file__).resolve().parents[3]


def test_goals_state_the_fcl_ratio_at_1e5_and_the_baseline_ratio_at_n1():
    rows = [Row("exact", 100_000, 0.2, 3), Row("fcl", 100_000, 2.0, 1)]
    baseline = {"baseline": "../base", "baseline_us": 100.0, "current_us": 160.0, "ratio": 1.6}
    lines = goals(rows, baseline)
    goal = f"(goal >= {GOAL_FCL_RATIO_1E5:g}x)"
    assert lines[0].startswith(f"N = 1e5: exact / FCL loop = 10.0x {goal}")
    assert lines[0].endswith(": met")
    assert lines[1].endswith("1.60x (goal <= 1.5x): NOT met")


def test_goals_say_what_was_not_measured():
    lines = goals([Row("exact", 100_000, 0.2, 3)])
    assert lines == ["N = 1e5: FCL loop not measured, no ratio",
                     "N = 1: no --baseline checkout given, the 1.5x budget is not checked"]


def test_baseline_of_this_checkout_against_itself_times_both_sides_on_the_same_poses():
    cube = np.array([2.0, 2.0, 2.0])
    poses = first_contact_poses(60, cube, cube, np.random.default_rng(0))
    result = compare_single_pair(poses, 60, REPO, REPO, rounds=1, log=lambda _: None)
    assert result["baseline_us"] > 0 and result["current_us"] > 0
    assert len(result["per_round_us"]["baseline"]) == 1
    assert np.isclose(result["ratio"], result["current_us"] / result["baseline_us"])


def test_mode_baseline_of_this_checkout_against_itself_reports_both_sides():
    from impactnet.training.bench.exact.baseline_modes import compare

    result = compare(REPO, REPO, "exact", "quay_crane", batch=200, rounds=1, log=lambda _: None)
    for side in ("baseline", "current"):
        figures = result[side]["exact"]
        assert figures["n1_us"] > 0 and figures["batch_us_per_pair"] > 0
