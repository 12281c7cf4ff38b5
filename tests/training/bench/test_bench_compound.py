"""The compound benchmark's smoke run: every figure measured, each goal stated."""
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
