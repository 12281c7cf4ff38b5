"""`impactnet train` and `impactnet evaluate` on a scene of compound pairs (the detail scene's
cell guide pair alone, quick): the labelled rows are written once and reused, the store's
``current`` names a bundle that reads back with the pair's decision and figures, and the
evaluation scores the learned path on fresh rows beside the decision."""
from __future__ import annotations

import json
import os

import pytest

from impactnet.cli import main
from impactnet.models.bundle.store import current_version, resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from tests.compound_bundle import guide_scene

PAIR = "cell_guide/container40"


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compound_scene")
    scene = guide_scene(folder)
    argv = ["train", "--scene", str(scene), "--quick", "--rows", "400", "--out",
            str(folder / "store"), "--data", str(folder / "data")]
    assert main(argv) == 0
    return folder, scene, argv


def test_train_publishes_a_bundle_with_each_pairs_decision(trained, capsys):
    folder, _, _ = trained
    store = folder / "store"
    assert current_version(store) is not None
    bundle = read_bundle(resolve_bundle(store))
    assert bundle.pairs == {} and set(bundle.compound) == {PAIR}
    decision = bundle.compound[PAIR].decision
    assert decision["serve"] in ("learned", "exact-only") and "speedup_n1" in decision["figures"]
    assert bundle.manifest["rebuild_command"].startswith("impactnet train --scene guide_only")
    data = json.loads((folder / "data" / "guide_only.compound.json").read_text())
    assert data["n_per_pair"] == 400


def test_a_second_run_reuses_the_labelled_rows(trained, capsys):
    folder, _, argv = trained
    assert main(argv) == 0
    assert "labelled rows from" in capsys.readouterr().err


def test_evaluate_scores_the_pairs_beside_their_decision(trained, monkeypatch, capsys):
    from impactnet.training.bench.timing import THREAD_VARIABLES

    for name in THREAD_VARIABLES:  # evaluate pins BLAS threads in os.environ: restore them
        monkeypatch.setenv(name, os.environ.get(name, "1"))
    folder, scene, _ = trained
    out = folder / "evaluation"
    assert main(["evaluate", "--scene", str(scene), "--bundle", str(folder / "store"),
                 "--quick", "--rows", "150", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert PAIR in report and "Served per pair" in report
    result = json.loads((out / "evaluation.json").read_text())
    (pair,) = result["pairs"]
    assert pair["scored"]["rows"] > 100 and set(pair["goals"]) == {
        "exact_set_answered", "missed_share", "fallback_share", "p99_errors"}
