"""The shipped default bundle (models/bundles/quay_crane) meets a conservative accuracy floor on
freshly drawn data of every pair of the default scene, through the public entry point.

The floors are about twice the figures measured on 100,000 held-out rows per pair by
`impactnet evaluate` (docs/evaluation/report.md), so that a broken bundle or a regression in the
inference code fails here while sampling noise on 3,000 rows does not.
"""
from __future__ import annotations

import numpy as np
import pytest

import models
from models.bundle_store import resolve_bundle
from models.bundles import read_bundle
from models.exact import box_box
from models.predictors import DEFAULT_BUNDLE
from models.scenes import load_scene
from training.evaluate_data import INPUTS, datagen_config, held_out_rows
from training.evaluate_metrics import row_record

#: Test rows per pair (fresh: a seed no training or evaluation run uses).
ROWS = 3000
SEED = 987_654
#: Floors (point errors in % of the smaller body's shortest edge, normals in degrees).
COMMITTEE_POINT_MEDIAN_PCT = 0.5
COMMITTEE_POINT_P95_PCT = 5.0
AUTO_POINT_P99_PCT = 4.0
AUTO_NORMAL_P99_DEG = 1.0
AUTO_FALLBACK_MAX = 0.2


@pytest.fixture(scope="module")
def shipped():
    path = resolve_bundle(DEFAULT_BUNDLE)
    return read_bundle(path), load_scene("quay_crane")


def test_the_default_bundle_ships_and_matches_the_default_scene(shipped):
    bundle, scene = shipped
    assert bundle.manifest["scene"] == {"name": "quay_crane", "hash": scene.hash()}
    assert set(bundle.pairs) == {p.key for p in scene.pairs}


@pytest.mark.parametrize("index", range(10))
def test_shipped_bundle_meets_the_floor_on_fresh_data(shipped, index):
    bundle, scene = shipped
    data = held_out_rows(scene, index, ROWS, SEED, datagen_config(bundle.manifest))
    args = [data[k] for k in INPUTS]
    exact = box_box(*args)
    committee = row_record(models.load_predictor("committee", bundle)(*args), data, "committee")
    auto = row_record(models.load_predictor("auto", bundle)(*args), data, "auto")
    assert committee.region_ok.all()  # the region classifier is the exact labeller
    np.testing.assert_array_equal(committee.predicted, exact.colliding)
    point = committee.point_pct[committee.both]
    assert np.median(point) <= COMMITTEE_POINT_MEDIAN_PCT
    assert np.percentile(point, 95) <= COMMITTEE_POINT_P95_PCT
    assert np.percentile(auto.point_pct[auto.both], 99) <= AUTO_POINT_P99_PCT
    assert np.percentile(auto.normal_deg[auto.both], 99) <= AUTO_NORMAL_P99_DEG
    assert auto.fallback.mean() <= AUTO_FALLBACK_MAX
