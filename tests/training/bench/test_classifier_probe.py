"""The classifier probe (issue #21's feasibility measurement): its labels are the oracle's part
pairs row by row, and its figures are shares that behave as a margin sweep must."""
import numpy as np
import pytest

from impactnet.training.bench.learned import classifier_probe as cp

pytest.importorskip("torch")


@pytest.fixture(scope="module")
def stacking_rows():
    return cp.labelled_rows("container40/container40", 150, 3, None)


def test_the_label_matrix_holds_exactly_each_rows_touching_part_pairs(stacking_rows):
    data = stacking_rows
    n = len(data["push"])
    pose = np.repeat(np.arange(n), np.diff(data["contact_offsets"]))
    keys = data["contact_part_a"].astype(int) * 4096 + data["contact_part_b"]
    vocab, labels, unknown = cp.label_matrix(keys, pose, n, np.arange(n))
    assert len(unknown) == 0 and labels.sum() == len(keys)
    for row in range(n):
        assert set(vocab[labels[row] > 0.5]) == set(keys[pose == row])
    _, _, unknown = cp.label_matrix(keys, pose, n, np.arange(n // 2))  # pairs unseen in training
    assert set(unknown) <= set(range(n // 2, n))


def test_the_probe_reports_shares_that_fall_with_the_margin(stacking_rows):
    figures = cp.probe(stacking_rows, "container40/container40", hidden=16, epochs=2, seed=0)
    assert set(figures) == {"rows", "global", *(f"local_{c}" for c in cp.CORNERS)}
    for name in ("global", "local_fl"):
        f = figures[name]
        assert f["labels"] > 0 and 0.0 <= f["exact_set"] <= 1.0
        fallback = [f["margins"][m]["fallback"] for m in cp.MARGINS]
        assert all(0.0 <= x <= 1.0 for x in fallback)
        assert fallback == sorted(fallback, reverse=True)  # a wider margin answers more rows
    assert figures["local_fl"]["labels"] < figures["global"]["labels"]
    assert "| global |" in cp.report(figures)


def test_expert_figures_are_error_ratios_of_the_most_frequent_part_pairs(stacking_rows):
    entries = cp.expert_figures(stacking_rows, "container40/container40", top=2, hidden=8,
                                epochs=2, seed=0)
    assert len(entries) == 2 and entries[0]["rows"] >= entries[1]["rows"]
    for entry in entries:
        whole, region = entry["part pair"], entry["largest region"]
        assert whole["rows"] == entry["rows"] >= region["rows"] > 0
        for figures in (whole, region):
            assert all(np.isfinite(figures[k]) and figures[k] >= 0.0
                       for k in ("depth", "normal", "point"))
    assert "| largest region |" in cp.expert_report(entries)


def test_the_learning_curve_trains_on_growing_prefixes_and_scores_the_same_rows(stacking_rows):
    curve = cp.learning_curve(stacking_rows, "container40/container40", [30, 100], hidden=8,
                              seed=0)
    assert [f["train_rows"] for f in curve] == [30, 100]
    assert curve[0]["labels"] <= curve[1]["labels"]  # more rows see more part pairs
    for f in curve:
        assert 0.0 <= f["exact_set"] <= 1.0 and set(f["margins"]) == set(cp.MARGINS)
