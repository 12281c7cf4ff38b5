"""The spreader's HTTP bench (issue #32, goal 4): its poses stay around the landing pose, MuJoCo's
loop answers contacts on them, and a small run over a real loopback server reports every figure
against its goal."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.training.bench.http import spreader_speed as bench


def test_the_poses_are_small_moves_of_the_landing_pose_about_random_axes():
    position, quaternion = bench.landing_poses(500, seed=3)
    assert np.abs(position - bench.LANDED).max() <= bench.SHIFT_M
    np.testing.assert_allclose(np.linalg.norm(quaternion, axis=1), 1.0, atol=1e-12)
    angle = 2.0 * np.arccos(np.clip(quaternion[:, 0], -1.0, 1.0))
    assert angle.max() <= bench.TURN_RAD + 1e-12 and angle.max() > 0.5 * bench.TURN_RAD
    axes = quaternion[:, 1:] / np.linalg.norm(quaternion[:, 1:], axis=1)[:, None]
    assert np.abs(axes.mean(axis=0)).max() < 0.15  # spread over the sphere, not one axis


def test_mujoco_s_loop_finds_the_twistlocks_in_the_castings():
    position, quaternion = bench.landing_poses(20)
    out = bench.mujoco_loop(position, quaternion)
    assert out["poses"] == 20 and out["seconds"] > 0
    assert out["contacts"] >= 15  # most poses touch (a pose lifted 5 mm may clear by 0.5 mm)


@pytest.mark.slow
def test_a_small_run_reports_every_figure_against_its_goal():
    out = bench.measure(poses=50, requests=20, log=lambda *_: None)
    assert 40 <= out["batch"]["colliding"] <= 50
    assert out["contact_over_floor"] > 0 and out["batch_over_mujoco"] > 0
    text = bench.report(out)
    assert "POST /v2/contact p50, the spreader pair" in text and "50 poses" in text
