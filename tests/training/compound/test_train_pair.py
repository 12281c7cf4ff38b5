"""Training of one compound pair (quick configuration, the cell guide pair): the classifiers
are calibrated (no validation row misses a touching pair in the vocabulary) and name a coarse
region for each label, well above chance after a few epochs, every region has a measured
expert choice, the decision carries the issue's figures, and the bundle written from it reads
back with a chain that answers like the oracle on the held-out rows it names."""
import numpy as np

from impactnet.models.compound import compound_answer
from impactnet.models.learned.bundle_loader import bundle_in_memory, read_bundle, write_bundle
from impactnet.models.learned.compound import chain_of
from impactnet.models.scenes import load_scene
from impactnet.training.compound.classify import CANDIDATE_FLOOR
from impactnet.training.compound.rows import split_rows
from tests.compound_bundle import GUIDE_PAIR, guide_entry, guide_manifest, guide_rows

FIGURES = {"rows", "answered_by", "fallback_share", "exact_set_answered", "missed_share",
           "missed_rows", "depth_p99_over_tolerance", "normal_p99_deg",
           "normal_p99_over_tolerance", "point_p99_over_tolerance", "batch_poses",
           "oracle_n1_us", "auto_n1_us", "oracle_batch_us_per_pose", "auto_batch_us_per_pose",
           "speedup_n1", "speedup_batch", "regions"}


def test_the_decision_records_every_figure_the_rule_uses():
    entry, _, _ = guide_entry()
    decision = entry["decision"]
    assert decision["serve"] in ("learned", "exact-only")
    assert FIGURES <= set(decision["figures"])
    assert (decision["serve"] == "learned") == (decision["reasons"] == [])
    assert decision["rule"]["speedup_required"] == 2.0
    named = decision["figures"]["regions"]
    assert named["contacts"] > 0 and named["candidate_share"] > 0.9


def test_each_label_has_region_slots_named_well_above_chance():
    entry, _, _ = guide_entry()
    for group in entry["groups"]:
        if group["labels"]:
            slots = np.array(group["regions"])
            assert set(slots[:, 0]) == set(range(len(group["labels"])))
            chance = len(group["labels"]) / len(slots)  # a uniform pick among a label's slots
            assert group["figures"]["region_accuracy_validation"] > 2 * chance
            assert entry["decision"]["figures"]["regions"]["region_exact_share"] > 2 * chance


def test_every_group_is_calibrated_and_every_region_has_a_measured_expert():
    entry, _, _ = guide_entry()
    for group in entry["groups"]:
        if group["labels"]:
            assert group["temperature"] > 0
            assert CANDIDATE_FLOOR <= group["candidate_min"] <= 0.5
    assert entry["regions"]
    for region in entry["regions"].values():
        assert region["expert"] in ("committee", "exact-part")
        if region["expert"] == "committee":
            ratios = region["figures"]["p99_over_tolerance"]
            assert max(ratios.values()) <= 1.0


def test_the_bundle_reads_back_and_its_chain_matches_the_oracle_on_named_pairs(tmp_path):
    manifest, tensors = guide_manifest()
    path = write_bundle(tmp_path / "b", manifest, tensors)
    bundle = read_bundle(path)
    models = bundle.compound[GUIDE_PAIR]
    assert models.serve == "learned" and models.classifiers
    scene = load_scene("quay_crane_detail")
    a, b = GUIDE_PAIR.split("/")
    chain = chain_of(models, scene.body(a).parts, scene.body(b).parts)
    rows = split_rows(guide_rows(), 0)
    test = rows.test
    got = chain.answer(np.zeros(3), [1.0, 0, 0, 0], rows.position[test], rows.quaternion[test])
    want = compound_answer(chain.parts_a, np.zeros(3), [1.0, 0, 0, 0], chain.parts_b,
                           rows.position[test], rows.quaternion[test])
    same = np.diff(got.parts.offsets) == np.diff(want.parts.offsets)
    assert same.mean() > 0.8  # a quick classifier names most sets; named ones are exact
    np.testing.assert_allclose(got.summary.depth[same & (got.predictor == "exact-part")],
                               want.summary.depth[same & (got.predictor == "exact-part")],
                               atol=1e-12)
    assert bundle_in_memory(manifest, tensors).compound[GUIDE_PAIR].key == GUIDE_PAIR


def test_the_best_case_first_decides_without_a_classifier_where_nothing_can_pay():
    import dataclasses

    from impactnet.training.compound.pair import train_compound_pair
    from impactnet.training.compound.settings import compound_config

    scene = load_scene("quay_crane_detail")
    pair = scene.pairs[[p.key for p in scene.pairs].index(GUIDE_PAIR)]
    config = dataclasses.replace(compound_config(0, quick=True), best_case_first=True)
    entry, tensors, _ = train_compound_pair(scene, pair, guide_rows(), config, log=lambda m: 0)
    best = entry["best_case"]
    assert best["oracle_n1_us"] > 0 and best["best_case_batch_us_per_pose"] > 0
    if min(best["speedup_n1"], best["speedup_batch"]) < 2.0:  # the guide: ~1.1x (measured)
        assert entry["decision"]["serve"] == "exact-only" and "groups" not in entry
        assert "no classifier can make this pair pay" in entry["decision"]["reasons"][0]
        assert tensors == {}
    else:
        assert entry["groups"]
