"""The expert choice per region (a part pair and a coarse region of its contact): a committee
is kept only where its p99 errors on validation rows meet the tolerances (here loose ones, so
it is kept; tight ones, so it is not), its manifest entry carries what the served committee
needs, its contacts are the region's, and a chain with it answers the region's contacts as
``learned``."""
import numpy as np

from impactnet.models.learned.compound.chain import CompoundChain
from impactnet.models.learned.compound.groups import part_groups
from impactnet.models.scenes import load_scene
from impactnet.training.compound.classify import ClassifierConfig, train_group
from impactnet.training.compound.experts import ExpertConfig, Tolerances, fit_regions
from impactnet.training.compound.rows import split_rows
from impactnet.training.fit.loop import FitConfig
from tests.compound_bundle import guide_rows

FIT = FitConfig(batch_size=64, steps_per_epoch=10, max_epochs=3, patience=2, val_rows=512)
CONFIG = ExpertConfig(members=2, hidden=(8, 8), max_regions=2, min_rows=20, fit=FIT)


def _fit(tol, point_tol):
    scene = load_scene("quay_crane_detail")
    parts_a, parts_b = scene.body("cell_guide").parts, scene.body("container40").parts
    rows = split_rows(guide_rows(), 0)
    return rows, parts_a, parts_b, fit_regions(rows, parts_a, parts_b, lambda i, j: point_tol,
                                               tol, CONFIG, "t", 0)


def test_a_committee_within_the_tolerance_is_kept_with_what_serving_needs():
    rows, parts_a, parts_b, (committees, entries, tensors, specs) = _fit(
        Tolerances(depth_m=1.0, normal_deg=180.0), point_tol=10.0)
    assert len(committees) == 2
    for (i, j, code), committee in committees.items():
        entry = entries[f"{i}/{j}/{code}"]
        assert entry["expert"] == "committee" and len(entry["members"]) == 2
        assert entry["normal_spread_max_deg"] >= 0 and entry["depth_spread_max_m"] >= 0
        assert set(entry["members"]) <= set(specs)
        assert committee.region == code
        assert committee.contact_type_code == entry["contact_type_code"] == code // 36
        in_region = (rows.part_a == i) & (rows.part_b == j) & (rows.region == code)
        assert entry["train_contacts"] == np.isin(rows.pose[in_region], rows.train).sum()
    assert {name.rsplit(".", 1)[0] for name in tensors} == set(specs)
    groups = part_groups(parts_a, parts_b)
    clf = train_group(rows, groups, len(groups) - 1, ClassifierConfig(hidden=(8,), fit=FIT),
                      "t.clf", 0)[0]
    chain = CompoundChain("a/b", parts_a, parts_b, (clf,), committees)
    answer = chain.answer(np.zeros(3), [1.0, 0, 0, 0], rows.position[rows.test],
                          rows.quaternion[rows.test], fallback=False)
    assert "learned" in set(answer.predictor)


def test_a_committee_outside_the_tolerance_leaves_the_exact_part_solver():
    _, _, _, (committees, entries, tensors, specs) = _fit(
        Tolerances(depth_m=1e-9, normal_deg=1e-6), point_tol=1e-9)
    assert committees == {} and tensors == {} and specs == {}
    measured = [e for e in entries.values() if e["figures"].get("p99_over_tolerance")]
    assert len(measured) == 2 and all(e["expert"] == "exact-part" for e in measured)
    assert all(max(e["figures"]["p99_over_tolerance"].values()) > 1 for e in measured)
