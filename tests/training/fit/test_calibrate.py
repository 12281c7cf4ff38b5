"""Calibration of auto on synthetic numbers: the thresholds meet the target, fallback is small."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.training.fit.calibrate import (
    NO_LIMIT,
    THRESHOLD_NAMES,
    CalibrationTarget,
    auto_keep,
    calibrate,
    calibration_scores,
)

TARGET = CalibrationTarget(normal_deg=1.0, point_fraction=0.02)


def synthetic(n=40_000, seed=0):
    """Rows whose errors are large exactly where one of the four scores is bad.

    Confidence below 0.2 (~4 % of rows) ruins the normal; a normal spread above 2 degrees
    (~3 %) ruins the normal too; a point spread above 0.05 (~2 %) ruins the point; a depth
    outside the range by more than 0.004 (~2 %) ruins both. Good rows have errors well inside
    the target.
    """
    rng = np.random.default_rng(seed)
    confidence = np.where(rng.random(n) < 0.04, rng.uniform(0.0, 0.2, n),
                          rng.uniform(0.2, 1.0, n))
    normal_spread = np.where(rng.random(n) < 0.03, rng.uniform(2.0, 10.0, n),
                             rng.uniform(0.0, 2.0, n))
    point_spread = np.where(rng.random(n) < 0.02, rng.uniform(0.05, 0.2, n),
                            rng.uniform(0.0, 0.05, n))
    depth = np.where(rng.random(n) < 0.02, rng.uniform(0.015, 0.03, n),
                     rng.uniform(0.0, 0.01, n))
    output = np.zeros((n, 7))
    output[:, 6] = depth
    pred = {"confidence": confidence, "normal_spread_deg": normal_spread,
            "point_spread": point_spread, "output": output, "region": np.ones(n, int),
            "exact": np.zeros(n, bool)}
    bad_depth = depth > 0.014
    normal_err = np.where((confidence < 0.2) | (normal_spread > 2.0) | bad_depth, 5.0,
                          rng.uniform(0, 0.5, n))
    point_err = np.where((point_spread > 0.05) | bad_depth, 0.1, rng.uniform(0, 0.01, n))
    return calibration_scores(pred, (0.0, 0.01)), normal_err, point_err


def test_thresholds_meet_the_target_with_a_small_fallback():
    scores, normal_err, point_err = synthetic()
    result = calibrate(scores, normal_err, point_err, TARGET)
    assert result["met"]
    keep = auto_keep(scores, result["thresholds"])
    assert np.percentile(normal_err[keep], 99) <= TARGET.normal_deg
    assert np.percentile(point_err[keep], 99) <= TARGET.point_fraction
    bad = (normal_err > TARGET.normal_deg) | (point_err > TARGET.point_fraction)
    # The bad rows (~10.3 %) must go, except 1 % of the kept rows per error (normal, point);
    # the quantile grid may cost a few % more.
    assert bad.mean() - 0.02 <= 1.0 - keep.mean() <= bad.mean() + 0.04
    assert result["fallback_share"] == pytest.approx(1.0 - keep.mean())
    assert set(result["thresholds"]) == set(THRESHOLD_NAMES)


def test_nothing_is_dropped_when_every_row_is_good():
    scores, normal_err, point_err = synthetic()
    result = calibrate(scores, normal_err * 0.0, point_err * 0.0, TARGET)
    assert result["met"] and result["fallback_share"] == 0.0
    assert list(result["thresholds"].values()) == list(NO_LIMIT)


def test_infeasible_target_sends_every_row_to_exact():
    scores, normal_err, point_err = synthetic()
    result = calibrate(scores, normal_err + 10.0, point_err, TARGET)
    assert not result["met"]
    assert np.isfinite(list(result["thresholds"].values())).all()
    # No committee answer that misses the tolerance is ever kept: auto answers exactly.
    assert result["fallback_share"] == 1.0
    assert not auto_keep(scores, result["thresholds"]).any()
    assert not result["best_infeasible"]["met"]


def test_mismatched_rows_are_never_kept_when_separable():
    """A contact / none mismatch (+inf error) with a bad depth is dropped by the depth test."""
    scores, normal_err, point_err = synthetic()
    bad_depth = scores[3] > 0.004
    result = calibrate(scores, np.where(bad_depth, np.inf, normal_err),
                       np.where(bad_depth, np.inf, point_err), TARGET)
    assert result["met"]
    keep = auto_keep(scores, result["thresholds"])
    assert np.isfinite(normal_err[keep]).all() and not (keep & bad_depth).any()


def test_rows_answered_exactly_are_never_kept():
    """Rows of a region without a committee go to the exact solver whatever the thresholds:
    calibration counts them as fallback (an infinite score), never as kept."""
    n = 1000
    exact = np.arange(n) % 10 == 0
    pred = {"confidence": np.ones(n), "normal_spread_deg": np.zeros(n),
            "point_spread": np.zeros(n), "output": np.zeros((n, 7)), "region": np.ones(n, int),
            "exact": exact}
    scores = calibration_scores(pred, (0.0, 0.01))
    keep = auto_keep(scores, dict(zip(THRESHOLD_NAMES, NO_LIMIT)))
    np.testing.assert_array_equal(keep, ~exact)
    result = calibrate(scores, np.zeros(n), np.zeros(n), TARGET)
    assert result["fallback_share"] == pytest.approx(0.1)
