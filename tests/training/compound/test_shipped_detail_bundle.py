"""The shipped bundle of ``quay_crane_detail``: it verifies, was built for the scene as it
stands, records every compound pair with the figures its decision rests on, and the rule
applied to those figures gives the recorded decision (an exact-only pair's models are kept and
load as a chain)."""
from __future__ import annotations

import numpy as np

from impactnet.models.bundle.store import resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.learned.compound import chain_of
from impactnet.models.predictors import DEFAULT_BUNDLE
from impactnet.models.scenes import load_scene
from impactnet.training.compound.measure import pair_decision
from impactnet.training.data.compound_dataset import compound_pairs

FOLDER = DEFAULT_BUNDLE.parent / "quay_crane_detail"


def test_the_shipped_bundle_matches_the_scene_and_covers_every_compound_pair():
    bundle = read_bundle(resolve_bundle(FOLDER))
    scene = load_scene("quay_crane_detail")
    assert bundle.manifest["scene"] == {"name": scene.name, "hash": scene.hash()}
    assert set(bundle.compound) == {p.key for p in compound_pairs(scene)}


def test_every_recorded_decision_follows_from_its_figures():
    bundle = read_bundle(resolve_bundle(FOLDER))
    for key, models in bundle.compound.items():
        figures = models.decision["figures"]
        serve, reasons = pair_decision(figures, figures)
        assert serve == models.serve, key
        assert reasons == models.decision["reasons"], key


def test_an_exact_only_pairs_models_are_kept_and_answer_as_a_chain():
    bundle = read_bundle(resolve_bundle(FOLDER))
    scene = load_scene("quay_crane_detail")
    models = bundle.compound["container40/spreader"]
    chain = chain_of(models, scene.body("container40").parts, scene.body("spreader").parts)
    lift = 2.591 / 2 + 0.4 + 0.005
    answer = chain.answer(np.zeros(3), [1.0, 0, 0, 0], [[0.0, 0.0045, lift]], [1.0, 0, 0, 0])
    np.testing.assert_allclose(answer.summary.depth, [0.00075], atol=1e-9)
