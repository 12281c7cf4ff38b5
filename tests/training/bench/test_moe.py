"""`impactnet bench moe`: per compound pair the learned path scored and timed against the
oracle with the rule applied beside the recorded decision (a quick run on the cell guide
pair); on the shipped bundle of the detailed scene, with the cost against detail and the HTTP
goals measured through a real server on loopback (slow)."""
from __future__ import annotations

import json

import pytest

from impactnet.cli import main
from tests.compound_bundle import guide_scene


def test_a_quick_run_scores_and_times_every_pair_beside_its_decision(tmp_path, capsys):
    scene = guide_scene(tmp_path)
    store = tmp_path / "store"
    assert main(["train", "--scene", str(scene), "--quick", "--rows", "300", "--out",
                 str(store), "--data", str(tmp_path / "data")]) == 0
    out = tmp_path / "bench"
    assert main(["bench", "moe", "--quick", "--scene", str(scene), "--bundle", str(store),
                 "--data", str(tmp_path / "data"), "--out", str(out)]) == 0
    result = json.loads((out / "moe.json").read_text())
    (pair,) = result["pairs"]
    assert pair["pair"] == "cell_guide/container40"
    assert pair["poses_from"] == "held-out rows of the training data"
    measured = pair["measured"]
    assert measured["oracle_n1_us"] > 0 and measured["auto_batch_us_per_pose"] > 0
    assert pair["decision"] in ("learned", "exact-only") and pair["recorded"] in (
        "learned", "exact-only")
    assert "cell_guide/container40" in (out / "moe.md").read_text()


@pytest.mark.slow
def test_the_shipped_detail_bundle_is_measured_with_detail_and_http(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench", "moe", "--quick", "--http", "--data", str(tmp_path / "none"),
                 "--out", str(out)]) == 0
    result = json.loads((out / "moe.json").read_text())
    assert [p["pair"] for p in result["pairs"]] == [
        "container40/container40", "container40/container20", "container40/spreader",
        "cell_guide/container40"]
    assert [r["sides"] for r in result["detail"]] == [8, 32, 128]
    http = result["http"]
    assert http["floor"]["p50_ms"] > 0 and http["batch_auto"]["poses"] == 500
    assert set(http["goals"]) == {"contact_auto_over_floor", "batch_speedup"}
    assert (out / "moe_cost_vs_detail.png").stat().st_size > 0
