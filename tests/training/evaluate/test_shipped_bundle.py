"""The shipped default bundle (models/bundles/quay_crane) meets a conservative accuracy floor on
freshly drawn data of every pair of the default scene, through the public entry point, and
answers one pair as it answers that pair in a batch.

The floors are about twice the figures measured on 100,000 held-out rows per pair by
`impactnet evaluate` (docs/evaluation/report.md), so that a broken bundle or a regression in the
inference code fails here while sampling noise on 3,000 rows does not. The committee's point
is judged on the rows its experts answer: elsewhere it is the exact labeller's by construction.
"""
from __future__ import annotations

import numpy as np
import pytest

from impactnet import models
from impactnet.models.box.exact import box_box
from impactnet.models.bundle.store import resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.learned.region_label import unclipped_points
from impactnet.models.predictors import DEFAULT_BUNDLE
from impactnet.models.scenes import load_scene
from impactnet.training.bench.methods import learned_bundle
from impactnet.training.evaluate.data import INPUTS, datagen_config, held_out_rows
from impactnet.training.evaluate.metrics import row_record

#: Test rows per pair (fresh: a seed no training or evaluation run uses).
ROWS = 3000
SEED = 987_654
#: Floors on the expert-answered rows (point errors in % of the smaller body's shortest edge).
EXPERT_POINT_MEDIAN_PCT = 7.0
EXPERT_POINT_P90_PCT = 75.0
#: Floors of auto over all rows (the scene's tolerance is 2 % and 1 degree). Since point rule 2
#: (the centre of pressure) the experts answer every tilted face contact and auto falls back on
#: 39-54 % of the rows per pair (docs/evaluation/report.md; 8.7 % under rule 1): the floor is
#: that measurement plus sampling room, so that a bundle that falls back on everything fails.
AUTO_POINT_P99_PCT = 4.0
AUTO_FALLBACK_MAX = 0.65
#: Rows per pair compared one by one against their batch answer.
ONE_BY_ONE_ROWS = 150
#: Agreement of the N = 1 and batch answers, as a share of the scene's point tolerance: the features
#: are float32 on both paths, rounded differently; the networks' input scales are floored so that
#: this rounding is not amplified (impactnet.training.fit.torch_mlp.INPUT_SCALE_FLOOR).
ONE_BY_ONE_TOL_SHARE = 0.2


@pytest.fixture(scope="module")
def shipped():
    """The shipped bundle's learned models, its recorded decisions lifted (the bundle serves
    every pair exact-only, issue #21: these tests are about the models it ships)."""
    return learned_bundle(DEFAULT_BUNDLE)[0], load_scene("quay_crane")


def _rows(shipped, index):
    bundle, scene = shipped
    data = held_out_rows(scene, index, ROWS, SEED, datagen_config(bundle.manifest))
    return data, [data[k] for k in INPUTS]


def test_the_shipped_bundle_serves_every_pair_exact_only_as_measured():
    """Issue #21's decision, recorded when the bundle was built: on this project's CPU the
    learned path was not 2x faster than the exact solver on any pair (docs/benchmarks/
    decide.md), so every mode answers every pair of the default scene as the exact solver."""
    served = read_bundle(resolve_bundle(DEFAULT_BUNDLE))
    scene = load_scene("quay_crane")
    assert {p.serve for p in served.pairs.values()} == {"exact-only"}
    for pair in served.pairs.values():
        figures = pair.decision["figures"]
        assert min(figures["speedup_n1"], figures["speedup_batch"]) < 2.0, pair.key
    data = held_out_rows(scene, 0, 200, SEED, datagen_config(served.manifest))
    args = [data[k] for k in INPUTS]
    for mode in ("single", "committee", "auto"):
        got = models.load_predictor(mode, served)(*args)
        assert (got.predictor == "exact").all()
        np.testing.assert_array_equal(got.point, box_box(*args).point)


def test_the_default_bundle_ships_and_matches_the_default_scene(shipped):
    bundle, scene = shipped
    assert bundle.manifest["scene"] == {"name": "quay_crane", "hash": scene.hash()}
    assert set(bundle.pairs) == {p.key for p in scene.pairs}
    assert bundle.manifest["validation_gate"]["passed"] is True


@pytest.mark.parametrize("index", range(10))
def test_shipped_bundle_meets_the_floor_on_fresh_data(shipped, index):
    bundle, _ = shipped
    data, args = _rows(shipped, index)
    exact = box_box(*args)
    committee = row_record(models.load_predictor("committee", bundle)(*args), data, "committee")
    auto = row_record(models.load_predictor("auto", bundle)(*args), data, "auto")
    assert committee.region_ok.all()  # the region classifier is the exact labeller
    np.testing.assert_array_equal(committee.predicted, exact.colliding)
    experts = committee.both & ~unclipped_points(*args)[1] & ~committee.fallback
    point = committee.point_pct[experts]
    assert experts.sum() > 40
    assert np.median(point) <= EXPERT_POINT_MEDIAN_PCT
    assert np.percentile(point, 90) <= EXPERT_POINT_P90_PCT
    assert np.percentile(auto.point_pct[auto.both], 99) <= AUTO_POINT_P99_PCT
    assert auto.fallback.mean() <= AUTO_FALLBACK_MAX


@pytest.mark.parametrize("index", [0, 3, 9])
@pytest.mark.parametrize("mode", ["committee", "auto"])
def test_shipped_bundle_answers_one_pair_as_in_a_batch(shipped, index, mode):
    bundle, scene = shipped
    _, args = _rows(shipped, index)
    predictor = models.load_predictor(mode, bundle)
    batch = predictor(*args)
    tol = ONE_BY_ONE_TOL_SHARE * scene.accuracy.point_fraction * scene.smaller_shortest_edge(
        scene.pairs[index])
    for i in range(ONE_BY_ONE_ROWS):
        one = predictor(*(a[i] for a in args))
        assert one.predictor[0] == batch.predictor[i], i
        for name in ("colliding", "contact_type_code", "feature_a", "feature_b", "axis"):
            assert getattr(one, name)[0] == getattr(batch, name)[i], (name, i)
        np.testing.assert_allclose(one.point[0], batch.point[i], rtol=0, atol=tol,
                                   err_msg=str(i))


#: Stacking poses: B set down flat on A (offsets, yaw, a small roll), the crane's main case.
STACK_ROWS = 1500
STACK_YAWS_DEG = (0.0, 0.5, 2.0)
STACK_ROLLS_RAD = (0.0, 1e-3)
STACK_DEPTH_M = 0.002


def _stacking(size_a, size_b, yaw_deg, roll, rng):
    n = STACK_ROWS
    half_yaw = 0.5 * np.radians(yaw_deg) * rng.choice([-1.0, 1.0], n)
    half_roll = 0.5 * roll * rng.choice([-1.0, 1.0], n)
    # q = q_yaw(z) * q_roll(x)
    q = np.column_stack([np.cos(half_yaw) * np.cos(half_roll),
                         np.cos(half_yaw) * np.sin(half_roll),
                         np.sin(half_yaw) * np.sin(half_roll),
                         np.sin(half_yaw) * np.cos(half_roll)])
    offset = np.column_stack([rng.uniform(-1.5, 1.5, n), rng.uniform(-0.3, 0.3, n),
                              np.full(n, 0.5 * (size_a[2] + size_b[2]) - STACK_DEPTH_M)])
    return [np.asarray(size_a), np.zeros(3), np.array([1.0, 0, 0, 0]), np.asarray(size_b),
            offset, q]


@pytest.mark.parametrize("pair", ["container40/container40", "container20/container40",
                                  "container40/spreader"])
def test_auto_stays_within_tolerance_on_stacking_poses(shipped, pair):
    """Regression: with a yaw of 0.5-2 degrees and parallel faces the face-face experts were
    30-150 % of the edge off with a small spread, and auto kept up to 79 % of those rows."""
    bundle, scene = shipped
    index = [p.key for p in scene.pairs].index(pair)
    size_a, size_b = scene.pair_sizes()[index]
    edge = scene.smaller_shortest_edge(scene.pairs[index])
    auto = models.load_predictor("auto", bundle)
    rng = np.random.default_rng(5)
    for yaw in STACK_YAWS_DEG:
        for roll in STACK_ROLLS_RAD:
            args = _stacking(size_a, size_b, yaw, roll, rng)
            exact, answer = box_box(*args), auto(*args)
            error = np.linalg.norm(answer.point - exact.point, axis=1)[exact.colliding] / edge
            assert error.max() <= scene.accuracy.point_fraction, (yaw, roll, error.max())
