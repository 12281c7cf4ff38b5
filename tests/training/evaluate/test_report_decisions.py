"""The evaluation report's "Served per pair" section (issue #21's per-pair decision)."""
from impactnet.training.evaluate.report import decisions

FIGURES = {"speedup_n1": 0.93, "speedup_batch": 0.71, "poses": 100_000, "fallback_share": 0.21,
           "normal_p99_deg": 0.0, "point_p99_fraction": 0.0137}


def test_each_pair_is_listed_with_what_serves_it_and_the_figures_behind_it():
    text = "\n".join(decisions({"decisions": {
        "box/plate": {"serve": "exact-only", "figures": FIGURES},
        "box/box": None}}))
    assert "| box/plate | exact-only | 0.93x | 0.71x at 100,000 | 21.0 % |" in text
    assert "| box/box | learned (no decision recorded) |" in text


def test_a_bundle_without_decisions_says_so():
    text = "\n".join(decisions({"decisions": {"box/plate": None}}))
    assert "records no per-pair decision" in text
