"""The per-pair decision of issue #21 (box pairs): the rule, and a quick measured run whose
figures are consistent (the decision itself depends on the machine's timings: not tested)."""
from dataclasses import replace

import pytest

from impactnet.models.scenes import Accuracy
from impactnet.training.bench import decide as dc

ACCURACY = Accuracy(normal_deg=1.0, point_fraction=0.02)
LEARNED_ROW = {"speedup_n1": 2.5, "speedup_batch": 3.0, "normal_p99_deg": 0.5,
               "point_p99_fraction": 0.01, "missed": 0}


@pytest.mark.parametrize("change", [{}, {"speedup_n1": 1.9}, {"speedup_batch": 1.5},
                                    {"normal_p99_deg": 1.2}, {"point_p99_fraction": 0.03},
                                    {"missed": 1}, {"normal_p99_deg": None}])
def test_a_pair_is_learned_only_when_twice_as_fast_at_both_sizes_and_within_tolerance(change):
    expected = "learned" if not change else "exact-only"
    assert dc.serve_decision(LEARNED_ROW | change, ACCURACY) == expected


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
        assert row["decision"] == dc.serve_decision(row, load_scene("quay_crane").accuracy)
    assert (tmp_path / "decide.md").read_text().count("**") == 2 * len(result["pairs"])
    assert (tmp_path / "decide.json").exists()


def test_a_scene_with_compound_pairs_is_refused_naming_them():
    from impactnet.models.scenes import SceneError

    with pytest.raises(SceneError, match="impactnet bench decide handles pairs of boxes only"):
        dc.decide(replace(dc.QUICK, scene="quay_crane_detail"))
