"""`impactnet evaluate` end to end: a tiny bundle is trained, evaluated, and the report, the JSON
and the figures are checked; the paper's metric of the exact solver is zero."""
import json

import numpy as np
import pytest
import safetensors.numpy

from impactnet.cli import main
from impactnet.models.bundle.format import WEIGHTS
from impactnet.models.bundle.store import resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle, write_bundle
from impactnet.models.predictors import ExactPredictor
from impactnet.models.scenes import load_scene
from impactnet.training.evaluate.cli import EXIT_GOAL_MISSED, EXIT_OK
from impactnet.training.evaluate.paper import cube_pair, paper_metric
from impactnet.training.evaluate.run import GOALS

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Keys every evaluation.json has at the top and for every pooled predictor.
TOP_KEYS = {"format", "format_version", "scene", "bundle", "config", "tolerance", "predictors",
            "pairs", "pooled", "paper", "goals", "goals_met", "seconds"}
PREDICTOR_KEYS = {"rows", "contacts", "both_colliding", "missed_contacts", "false_contacts",
                  "type_accuracy", "region_accuracy", "fallback_share", "normal_deg",
                  "point_pct", "depth_pct", "depth_mm", "pairs_per_s"}
STAT_KEYS = {"median", "mean", "p95", "p99", "max"}


def test_the_paper_metric_of_the_exact_solver_is_zero():
    assert cube_pair(load_scene("quay_crane")) == "cube/cube"
    out = paper_metric({"exact": ExactPredictor()}, seed=3, rows=(40, 40))
    for problem in ("with_discontinuities", "without_discontinuities"):
        measured = out["problems"][problem]["predictors"]["exact"]
        assert out["problems"][problem]["rows"] == 40
        assert measured["wrapped"]["MAE"] == pytest.approx(0.0, abs=1e-9)
        assert measured["normal_error_deg"]["max"] == pytest.approx(0.0, abs=1e-6)
        assert measured["predicted_separated"] == 0


@pytest.fixture(scope="module")
def quick_bundle(tmp_path_factory):
    out = tmp_path_factory.mktemp("bundle") / "quay_crane"
    # --no-gate: a quick bundle cannot meet the scene's tolerance; these tests check plumbing
    assert main(["train", "--scene", "quay_crane", "--out", str(out), "--seed", "0",
                 "--quick", "--no-progress", "--no-gate"]) == 0
    return out


@pytest.mark.slow
def test_train_then_evaluate_writes_report_json_and_figures(quick_bundle, tmp_path, capsys):
    out = tmp_path / "evaluation"
    assert main(["evaluate", "--scene", "quay_crane", "--bundle", str(quick_bundle),
                 "--out", str(out), "--quick", "--rows", "500"]) == EXIT_OK
    printed = capsys.readouterr().out
    assert "goals of issue 4" in printed
    results = json.loads((out / "evaluation.json").read_text())
    assert TOP_KEYS <= set(results)
    assert results["config"]["rows"] == 500 and len(results["pairs"]) == 10
    pooled = results["pooled"]["predictors"]
    assert set(pooled) == {"exact", "single", "committee", "auto"}
    for figures in pooled.values():
        assert PREDICTOR_KEYS <= set(figures)
        assert STAT_KEYS <= set(figures["normal_deg"]) and STAT_KEYS <= set(figures["point_pct"])
    assert pooled["exact"]["region_accuracy"] == 1.0
    assert pooled["exact"]["normal_deg"]["max"] == 0.0
    assert pooled["exact"]["rows"] == 5000
    assert set(results["pooled"]["boundary"]) == {"distance", "sat_margin"}
    paper = results["paper"]["problems"]["with_discontinuities"]["predictors"]
    assert {"committee", "auto"} <= set(paper) and "MAE" in paper["auto"]["wrapped"]
    assert len(results["goals"]) == len(GOALS)
    report = (out / "report.md").read_text()
    for heading in ("## Goals of issue 4", "## Every predictor, pooled", "## Per pair",
                    "## The paper's four-angle metric", "## Error against the distance",
                    "## Region and contact-type confusions"):
        assert heading in report
    for name in ("error_cdf.png", "boundary.png", "confusion.png"):
        assert (out / name).read_bytes()[:8] == PNG_SIGNATURE
        assert f"]({name})" in report


#: Shift of every expert's output mean in the broken bundle (points NONSENSE_SHIFT x L away).
NONSENSE_SHIFT = 3.0


@pytest.mark.slow
def test_check_fails_on_a_missed_goal(quick_bundle, tmp_path):
    """A bundle whose experts answer nonsense misses the committee's point goals, and --check
    turns the report into status 1 (the quick bundle itself can meet them: the committee's
    labeller answers most rows exactly)."""
    path = resolve_bundle(quick_bundle)
    weights = safetensors.numpy.load_file(str(path / WEIGHTS))
    tensors = {name: value + np.float32(NONSENSE_SHIFT if name.endswith(".out_mean")
                                        and "_r" in name else 0.0)
               for name, value in weights.items()}
    broken = write_bundle(tmp_path / "broken", read_bundle(path).manifest, tensors)
    assert main(["evaluate", "--bundle", str(broken), "--out", str(tmp_path / "report"),
                 "--quick", "--rows", "500", "--check"]) == EXIT_GOAL_MISSED
