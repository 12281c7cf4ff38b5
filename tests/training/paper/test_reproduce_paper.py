"""Tests of the paper reproduction: the --quick run end to end, the "without discontinuities"
region, the metrics on hand-made arrays and the determinism of training."""
from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
import torch

from impactnet.models.contacts import FACE_VERTEX
from impactnet.training.paper import data as pdata
from impactnet.training.paper import metrics as pm
from impactnet.training.paper.cli import add_arguments, run
from impactnet.training.paper.mlp import MLPConfig, PaperTrainConfig, train
from impactnet.training.paper.reproduce import PAPER_TABLES, SET_NAMES, deterministic_torch

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
PROBLEMS = ("with_discontinuities", "without_discontinuities")
#: Round-off allowance for float64 angle arithmetic (radians or metres, unit scale).
ROUNDOFF_TOL = 1e-12


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper") / "report"
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--quick", "--out", str(out), "--seed", "3"])
    return run(args), out


@pytest.fixture(scope="module")
def region_data():
    data, stats = pdata.region_set(600, np.random.default_rng(7),
                                   pdata.PaperDataConfig(chunk=20_000))
    return data, stats


def test_cli_defaults():
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args([])
    assert (args.quick, args.out, args.seed) == (False, "reports/paper", 0)


def test_quick_run_writes_report_with_both_tables(quick_run):
    rc, out = quick_run
    assert rc == 0
    report = (out / "report.md").read_text()
    for heading in ("## Table 1: with discontinuities", "## Table 2: without discontinuities"):
        assert heading in report
    for row in ("| ME |", "| MAE |", "| RMSE |"):
        assert report.count(row) >= 4  # raw and wrapped, both problems
    assert "| | Training | Cross-validation | External validation |" in report
    for value in ("0.4523", "0.5624", "-0.0008", "0.8667"):  # the paper's own figures
        assert value in report
    assert "impactnet reproduce-paper --quick" in report and "--seed 3" in report


def test_quick_run_writes_both_figures(quick_run):
    _, out = quick_run
    for name in ("figure5_with_discontinuities.png", "figure6_without_discontinuities.png"):
        assert (out / name).read_bytes()[:8] == PNG_MAGIC
        assert f"]({name})" in (out / "report.md").read_text()


def test_quick_run_tables_json_has_the_expected_keys(quick_run):
    _, out = quick_run
    t = json.loads((out / "tables.json").read_text(), parse_constant=pytest.fail)  # strict JSON
    assert t["paper"] == PAPER_TABLES and t["quick"] is True and t["seed"] == 3
    families = [row["family"] for row in t["diagnostics"]["rows"]]
    assert families == ["b_corners_on_a_plus_x", "a_positive_trihedron", "vertex_on_face"]
    for problem in PROBLEMS:
        ours = t["ours"][problem]
        for table in ("raw", "wrapped"):
            for s in SET_NAMES:
                assert set(ours[table][s]) == {"ME", "MAE", "RMSE"}
                assert all(np.isfinite(v) for v in ours[table][s].values())
        assert set(ours["per_output_raw"]["external_validation"]) == {
            "point azimuth", "point elevation", "force azimuth", "force elevation"}
        assert "mean" in ours["normal_error_deg"]["external_validation"]
        assert "mean" in ours["point_error_percent_of_edge"]["external_validation"]
        assert ours["hyper_parameters"]["grid"]
        assert len(ours["figure"]["desired"]) == len(ours["figure"]["predicted"]) > 0
    arch = {p: t["ours"][p]["hyper_parameters"]["architecture"] for p in PROBLEMS}
    assert arch == {"with_discontinuities": "6x20x18x4", "without_discontinuities": "6x20x17x4"}


def test_quick_run_without_discontinuities_is_one_region(quick_run):
    _, out = quick_run
    data = json.loads((out / "tables.json").read_text())["ours"]
    assert data["without_discontinuities"]["data"]["regions"] == 1
    assert list(data["without_discontinuities"]["data"]["contact_types"]) == ["face-vertex"]
    assert data["with_discontinuities"]["data"]["regions"] > 10


def test_region_set_labels_are_one_region(region_data):
    data, stats = region_data
    assert len(data) == 600
    assert np.all(data.contact_type_code == FACE_VERTEX)
    assert np.all(data.feature_a == 0) and np.all(data.feature_b == 25)  # face +x, vertex ---
    assert stats.mirrored >= stats.canonical > 0 and stats.drawn > stats.mirrored
    # the force direction is A's +x normal: outputs 3 and 4 are exactly 0
    np.testing.assert_array_equal(data.targets[:, 2:], 0.0)
    assert np.all(np.abs(data.targets[:, 0]) <= np.pi / 4 + 1e-3)  # no azimuth seam on +x
    assert np.all(np.abs(data.inputs[:, 3:]) <= np.pi / 2)  # Euler angles stay in range


def test_region_labels_equal_a_fresh_exact_call(region_data):
    data, _ = region_data
    fresh = pdata.label(data.inputs[:, :3], data.inputs[:, 3:], pdata.PaperDataConfig())
    np.testing.assert_array_equal(fresh.feature_b, data.feature_b)
    np.testing.assert_allclose(fresh.targets, data.targets, atol=ROUNDOFF_TOL)


def test_folding_mirror_images_is_exact_equivariance():
    config = pdata.PaperDataConfig()
    batch = pdata.stream(5_000, np.random.default_rng(11), config)
    rows, s = pdata.mirror_flips(batch)
    assert len(rows) > 0 and np.any(s != 1.0)  # real mirror images were found
    folded = pdata.fold(batch, rows, s, config)
    assert pdata.in_region(folded).all()
    np.testing.assert_allclose(folded.point, s * batch.point[rows], atol=1e-9)
    np.testing.assert_allclose(folded.normal, s * batch.normal[rows], atol=1e-9)
    np.testing.assert_allclose(folded.depth, batch.depth[rows], atol=1e-9)


def test_stream_has_every_contact_kind_and_paper_euler_range():
    data = pdata.stream(3_000, np.random.default_rng(5), pdata.PaperDataConfig())
    assert len(np.unique(data.contact_type_code)) >= 3
    assert np.all(np.abs(data.inputs[:, 3:]) <= np.pi / 2)
    assert np.all(np.abs(data.targets[:, [0, 2]]) <= np.pi)
    assert np.all(np.abs(data.targets[:, [1, 3]]) <= np.pi / 2)


def test_summary_on_hand_made_errors():
    e = np.array([[1.0, -1.0, 2.0, 0.0], [0.0, 3.0, -2.0, 1.0]])
    s = pm.summary(e)
    assert s["ME"] == pytest.approx(4.0 / 8)
    assert s["MAE"] == pytest.approx(10.0 / 8)
    assert s["RMSE"] == pytest.approx(np.sqrt(20.0 / 8))
    per = pm.per_output(e)
    assert per["point elevation"] == pytest.approx({"ME": 1.0, "MAE": 2.0,
                                                    "RMSE": np.sqrt(5.0)})


def test_wrapped_errors_forgive_a_seam_flip_but_raw_do_not():
    desired = np.array([[np.pi - 0.01, 0.2, -np.pi + 0.01, -0.3]])
    predicted = np.array([[-np.pi + 0.01, 0.2, np.pi - 0.01, -0.3]])
    raw, wrapped = pm.errors(predicted, desired), pm.errors(predicted, desired, wrap=True)
    np.testing.assert_allclose(raw, [[-2 * np.pi + 0.02, 0, 2 * np.pi - 0.02, 0]], atol=1e-12)
    np.testing.assert_allclose(wrapped, [[0.02, 0, -0.02, 0]], atol=1e-12)
    assert pm.summary(raw)["MAE"] == pytest.approx((2 * np.pi - 0.02) / 2)
    assert pm.summary(wrapped)["MAE"] == pytest.approx(0.01)
    assert pm.summary(wrapped)["ME"] == pytest.approx(0.0, abs=1e-12)


def test_elevation_errors_are_never_wrapped():
    e = pm.errors(np.array([[0.0, 1.5, 0.0, -1.5]]), np.array([[0.0, -1.5, 0.0, 1.5]]), wrap=True)
    np.testing.assert_allclose(e, [[0.0, 3.0, 0.0, -3.0]])


def test_geometric_errors_on_hand_made_angles():
    desired = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, np.pi / 2, 0.0, np.pi / 2]])
    predicted = np.array([[np.pi / 2, 0.0, np.pi / 2, 0.0], [0.0, np.pi / 2, 2.0, np.pi / 2]])
    np.testing.assert_allclose(pm.normal_error_deg(predicted, desired), [90.0, 0.0], atol=1e-9)
    # +x face centre vs +y face centre of a cube of edge 2: sqrt(2) m = 70.71% of the edge
    np.testing.assert_allclose(pm.point_error_percent(predicted, desired, [2.0, 2.0, 2.0]),
                               [100 * np.sqrt(2) / 2, 0.0], atol=1e-9)
    exact = np.array([[1.01, 0.0, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(
        pm.point_error_percent(predicted, desired, [2.0, 2.0, 2.0], exact),
        [100 * np.hypot(1.01, 1.0) / 2, 0.0], atol=1e-9)


def test_training_is_deterministic_and_restores_torch_settings():
    data = pdata.stream(400, np.random.default_rng(2), pdata.PaperDataConfig())
    threads = torch.get_num_threads()
    cfg = PaperTrainConfig(max_epochs=3, patience=3, seed=4)
    with deterministic_torch():
        runs = [train(data.inputs[:300], data.targets[:300], data.inputs[300:],
                      data.targets[300:], MLPConfig(hidden=(20, 17)), cfg) for _ in range(2)]
    assert torch.get_num_threads() == threads
    np.testing.assert_array_equal(runs[0].predict(data.inputs), runs[1].predict(data.inputs))
    assert runs[0].history == runs[1].history and runs[0].n_parameters() == 569
