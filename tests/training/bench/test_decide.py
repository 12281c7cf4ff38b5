"""The per-pair decision of issue #21 (box pairs): the rule, and a quick measured run whose
figures are consistent (the decision itself depends on the machine's timings: not tested)."""
from dataclasses import replace

import pytest

from impactnet.models.scenes import Accuracy
from impactnet.training.bench.learned import decide as dc

ACCURACY = Accuracy(normal_deg=1.0, point_fraction=0.02)
HELD_OUT = {"normal_p99_deg": 0.2, "point_p99_fraction": 0.015}
LEARNED_ROW = {"poses": 5000, "speedup_n1": 2.5, "speedup_batch": 3.0, "normal_p99_deg": 0.5,
               "point_p99_fraction": 0.01, "missed": 0, "held_out": HELD_OUT}


@pytest.mark.parametrize("change", [{}, {"speedup_n1": 1.9}, {"speedup_batch": 1.5},
                                    {"normal_p99_deg": 1.2}, {"point_p99_fraction": 0.03},
                                    {"missed": 1}, {"normal_p99_deg": None},
                                    {"held_out": HELD_OUT | {"point_p99_fraction": 0.0206}},
                                    {"held_out": HELD_OUT | {"normal_p99_deg": 1.01}},
                                    {"held_out": HELD_OUT | {"normal_p99_deg": None}}])
def test_a_pair_is_learned_only_when_twice_as_fast_at_both_sizes_and_within_tolerance(change):
    serve, reasons = dc.serve_decision(LEARNED_ROW | change, ACCURACY)
    assert serve == ("learned" if not change else "exact-only")
    assert len(reasons) == (0 if not change else 1)


def test_a_fast_pair_whose_held_out_point_misses_the_tolerance_is_exact_only_saying_why():
    """Issue item 10: accuracy joins speed; the reason names the figure and the limit."""
    row = LEARNED_ROW | {"held_out": HELD_OUT | {"point_p99_fraction": 0.0206}}
    assert dc.serve_decision(row, ACCURACY) == (
        "exact-only",
        ["held-out auto p99 point 0.0206 > tolerance 0.02 (fraction of the shortest edge)"])


def test_a_slow_pair_that_also_misses_the_tolerance_gets_both_reasons():
    row = LEARNED_ROW | {"speedup_n1": 0.93, "speedup_batch": 0.6, "normal_p99_deg": 1.5}
    serve, reasons = dc.serve_decision(row, ACCURACY)
    assert serve == "exact-only"
    assert reasons == ["auto is 0.93x the exact solver's speed at N = 1 and 0.60x at "
                       "N = 5,000 (< 2x required)",
                       "first-contact auto p99 normal 1.5 > tolerance 1 (deg)"]


def test_a_quick_run_reports_every_pair_with_consistent_figures(tmp_path):
    config = replace(dc.QUICK, poses_per_pair=300, single_calls=20, warmup=2, repeats=1)
    result = dc.run(config, str(tmp_path))
    from impactnet.models.scenes import load_scene

    assert [p["pair"] for p in result["pairs"]] == [p.key for p in load_scene("quay_crane").pairs]
    for row in result["pairs"]:
        assert row["poses"] == 300 and row["decision"] in ("learned", "exact-only")
        assert 0.0 <= row["fallback_share"] <= 1.0
        assert sum(row["answered_by"].values()) == 300
        assert row["speedup_n1"] == pytest.approx(row["exact_n1_us"] / row["auto_n1_us"])
        assert (row["decision"], row["reasons"]) == dc.serve_decision(
            row, load_scene("quay_crane").accuracy)
        assert row["held_out"] is not None  # the shipped bundle records its test figures
    assert (tmp_path / "decide.md").read_text().count("**") == 2 * len(result["pairs"])
    assert (tmp_path / "decide.json").exists()


def test_a_scene_with_compound_pairs_is_refused_naming_them():
    from impactnet.models.scenes import SceneError

    with pytest.raises(SceneError, match="impactnet bench decide handles pairs of boxes only"):
        dc.decide(replace(dc.QUICK, scene="quay_crane_detail"))
