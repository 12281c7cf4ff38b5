"""The "vs MuJoCo" column of `impactnet bench`: scored per method, cached per set of rows, and
reported as unavailable (with the reason) when MuJoCo is missing."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.scenes import load_scene
from impactnet.training.bench import report
from impactnet.training.bench.accuracy import vs_mujoco
from impactnet.training.bench.measure import with_overrides
from impactnet.training.bench.methods import Answer, exact_method, fcl_box_method, predictor_method
from impactnet.training.bench.pose_sets import scene_poses
from impactnet.training.bench.runner import run_bench
from tests.training.bench.test_bench import TINY, TURN_DEG, perturbed

#: A plan without polygon grids: the column's cost is MuJoCo and the grid, a few seconds.
PLAN = with_overrides(TINY, grid_sizes=(), mujoco_poses=300)
#: The perturbed predictor's normal is turned by TURN_DEG: its median error against MuJoCo is
#: that angle wherever the exact normal agrees with MuJoCo's (most rows), to this (degrees).
TURN_SLACK_DEG = 0.05


@pytest.fixture(scope="module")
def results():
    pytest.importorskip("mujoco")
    methods = [exact_method(), predictor_method("perturbed", perturbed), fcl_box_method()]
    return run_bench(PLAN, methods=methods, log=lambda message: None)


def test_every_method_gets_a_vs_mujoco_summary(results):
    assert results["mujoco"]["available"] and results["mujoco"]["version"]
    for row in results["rows"]:
        summary = row["vs_mujoco"]
        assert summary["rows"] == min(PLAN.mujoco_poses, row["batch_n"])
        assert 0.0 <= summary["within"] <= 1.0 and summary["mujoco_contacts"] > 0


def test_perturbed_predictor_is_off_by_its_turn(results):
    rows = {(r["method"], r["pose_set"]): r["vs_mujoco"] for r in results["rows"]}
    for pose_set in ("scene", "figure2"):
        exact, bad = rows["exact", pose_set], rows["perturbed", pose_set]
        assert bad["within"] <= exact["within"]
        assert abs(bad["normal_deg_median"] - TURN_DEG) <= TURN_SLACK_DEG


def test_markdown_has_the_column_and_the_table(results):
    markdown = report.markdown(results)
    assert "vs MuJoCo: within 1° & 2 %" in markdown
    assert markdown.count("| method | poses compared | within 1° & 2 %") == 2


def test_methods_on_the_same_rows_share_one_reference(monkeypatch):
    pytest.importorskip("mujoco")
    poses = scene_poses(load_scene("quay_crane"), 200, 0)
    calls = []
    original = vs_mujoco.mujoco_reference
    monkeypatch.setattr(vs_mujoco, "mujoco_reference",
                        lambda args: calls.append(len(args[0])) or original(args))
    column = vs_mujoco.MujocoColumn(poses, max_rows=50)
    answer = Answer.from_contacts(box_box(*poses.args()))
    for _ in range(2):
        column.score(answer, np.arange(len(poses)))
    column.score(answer.take(np.arange(100)), np.arange(100))
    assert calls == [50, 50]


def test_column_says_why_when_mujoco_is_missing(monkeypatch):
    monkeypatch.setattr(vs_mujoco, "mujoco_missing", lambda: "mujoco is not installed (test)")
    results = run_bench(with_overrides(PLAN, scene_poses=100), methods=[exact_method()],
                        log=lambda message: None)
    assert results["mujoco"]["available"] is False
    assert all(row["vs_mujoco"] is None for row in results["rows"])
    assert "vs MuJoCo: not available: mujoco is not installed (test)." in report.markdown(
        results)
