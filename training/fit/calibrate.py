"""Calibration of ``auto``: the thresholds that decide which rows go to the exact solver.

``auto`` keeps the committee's answer for a row when all four tests pass (the contract):
confidence >= ``confidence_min``, normal spread <= ``normal_spread_max_deg``, point spread <=
``point_spread_max`` (fraction of e) and predicted depth within the scene's range widened by
``depth_margin`` (fraction of e); every other row is answered exactly (error 0).

:func:`calibrate` chooses the four thresholds on validation rows so that the rows the committee
keeps meet the target at the quantile (default: at most 1 % of the kept rows have a normal
error above ``CALIBRATION_MARGIN`` x the scene's normal tolerance, and at most 1 % a point error
above that share of the point tolerance, i.e. p99 within the target), while keeping as many
rows as possible (the smallest fallback share).

Search: every test is "score <= threshold" (confidence enters as its negative). Each axis gets
candidate thresholds at quantiles of its score (:data:`DROP_LEVELS`: the share of rows that
the test alone would drop) plus "no limit". Every row falls in one cell of the 4-D grid of
candidate intervals; a histogram of rows, of normal failures and of point failures per cell,
cumulated along the four axes, gives for every threshold combination at once the rows kept and
the failures among them. The feasible combination with the most kept rows wins (ties: the
fewest failures). If none is feasible, ``auto`` must not keep any committee answer for the
pair (a guess that misses the tolerance is worse than the exact answer's cost): the thresholds
are set to :data:`SEND_ALL_TO_EXACT`, ``met: false`` and the fallback share is 1; the least-bad
combination is still reported under ``best_infeasible`` for diagnosis.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Share of the scene's tolerance that calibration aims at on validation data, so that the
#: thresholds still hold on fresh data (validation and test differ by sampling noise).
CALIBRATION_MARGIN = 0.8
#: Per-axis shares of rows that a single test may drop, where candidate thresholds are placed.
DROP_LEVELS = (0.0005, 0.001, 0.002, 0.003, 0.005, 0.0075, 0.01, 0.015, 0.02, 0.03, 0.04,
               0.05, 0.07, 0.1, 0.15, 0.2, 0.3)
#: Threshold values meaning "no limit" (finite, as the manifest holds only finite numbers):
#: confidence 0, spreads of 180 degrees and 10 edges, a depth margin of one edge.
NO_LIMIT = (0.0, 180.0, 10.0, 1.0)
#: Thresholds that keep no row in practice: a row would need a confidence of exactly 1 and
#: zero spreads and depth margin; used when no combination meets the target.
SEND_ALL_TO_EXACT = (1.0, 0.0, 0.0, 0.0)
#: Names of the four thresholds, in axis order (the manifest's ``auto`` keys).
THRESHOLD_NAMES = ("confidence_min", "normal_spread_max_deg", "point_spread_max",
                   "depth_margin")


@dataclass(frozen=True)
class CalibrationTarget:
    """What the kept rows must meet."""

    normal_deg: float  # normal error bound, degrees (scene tolerance x margin)
    point_fraction: float  # point error bound, fraction of e (scene tolerance x margin)
    quantile: float = 0.99  # share of kept rows that must be within both bounds


def calibration_scores(pred: dict, depth_fraction: tuple[float, float]) -> np.ndarray:
    """The four "keep if <= threshold" scores of every row, (4, n) float64.

    ``pred``: :func:`impactnet.training.fit.pair_eval.committee_predictions` output. Rows predicted
    "none" have spreads 0 and no depth excess; rows ``auto`` answers exactly anyway
    (``pred["auto_exact"]``, else ``pred["exact"]``: a region without a committee, a clipped contact
    of impactnet.models.learned.pair_runtime.AUTO_EXACT_TYPES) get an infinite depth excess, so that
    they count as fallback.
    """
    lo, hi = depth_fraction
    depth = pred["output"][:, 6]
    contact = pred["region"] != 0
    excess = np.where(contact, np.maximum(np.maximum(lo - depth, depth - hi), 0.0), 0.0)
    excess[pred.get("auto_exact", pred["exact"])] = np.inf
    return np.stack([-pred["confidence"], pred["normal_spread_deg"], pred["point_spread"],
                     excess]).astype(np.float64)


def _candidates(score: np.ndarray, unlimited: float) -> np.ndarray:
    """Ascending "keep if <=" candidates of one axis: score quantiles, then "no limit"."""
    levels = 1.0 - np.asarray(DROP_LEVELS)
    finite = score[np.isfinite(score)]  # rows answered exactly anyway score +inf
    cuts = np.unique(np.quantile(finite, levels)) if finite.size else np.empty(0)
    return np.concatenate([cuts[cuts < unlimited], [unlimited]])


def _cumulate(cells: np.ndarray, weights: np.ndarray, shape: tuple) -> np.ndarray:
    """Histogram of ``weights`` over flat cell ids, cumulated along every axis."""
    hist = np.bincount(cells, weights=weights, minlength=int(np.prod(shape))).reshape(shape)
    for axis in range(len(shape)):
        hist = np.cumsum(hist, axis=axis)
    return hist


def calibrate(scores: np.ndarray, normal_err: np.ndarray, point_err: np.ndarray,
              target: CalibrationTarget) -> dict:
    """Thresholds of ``auto`` from validation rows (module docstring).

    Parameters
    ----------
    scores : ndarray, shape (4, n)
        :func:`calibration_scores`.
    normal_err, point_err : ndarray, shape (n,)
        The committee's errors (degrees, fraction of e; +inf for a contact / none mismatch).
    target : CalibrationTarget

    Returns
    -------
    dict
        ``thresholds`` (the manifest's ``auto`` block), ``met`` (bool), ``fallback_share``,
        ``kept_failure_share`` (normal, point) on the calibration rows.
    """
    unlimited = (-NO_LIMIT[0],) + NO_LIMIT[1:]
    axes = [_candidates(s, u) for s, u in zip(scores, unlimited)]
    shape = tuple(len(a) for a in axes)
    bins = [np.searchsorted(a, s, side="left") for a, s in zip(axes, scores)]
    beyond = np.zeros(scores.shape[1], dtype=bool)  # above "no limit": never kept
    for b, a in zip(bins, axes):
        beyond |= b >= len(a)
    cells = np.ravel_multi_index([np.minimum(b, len(a) - 1) for b, a in zip(bins, axes)], shape)
    keep = (~beyond).astype(np.float64)
    kept = _cumulate(cells, keep, shape)
    bad_n = _cumulate(cells, keep * (normal_err > target.normal_deg), shape)
    bad_p = _cumulate(cells, keep * (point_err > target.point_fraction), shape)
    allowed = (1.0 - target.quantile) * kept
    feasible = (bad_n <= allowed) & (bad_p <= allowed) & (kept > 0)
    worst = np.maximum(bad_n, bad_p) / np.maximum(kept, 1.0)
    if feasible.any():
        rank = np.where(feasible, kept - 1e-6 * worst, -np.inf)
    else:
        rank = -worst + 1e-12 * kept
    best = np.unravel_index(int(np.argmax(rank)), shape)
    values = [float(a[i]) for a, i in zip(axes, best)]
    values[0] = -values[0]
    n = scores.shape[1]
    result = {"thresholds": dict(zip(THRESHOLD_NAMES, values)),
              "met": bool(feasible.any()),
              "fallback_share": float(1.0 - kept[best] / max(n, 1)),
              "kept_failure_share": [float(bad_n[best] / max(kept[best], 1.0)),
                                     float(bad_p[best] / max(kept[best], 1.0))]}
    if not result["met"]:
        result = {"thresholds": dict(zip(THRESHOLD_NAMES, SEND_ALL_TO_EXACT)), "met": False,
                  "fallback_share": 1.0, "kept_failure_share": [0.0, 0.0],
                  "best_infeasible": result}
    return result


def auto_keep(scores: np.ndarray, thresholds: dict) -> np.ndarray:
    """Rows (n,) bool that ``auto`` leaves to the committee under ``thresholds``."""
    limits = np.array([-thresholds["confidence_min"]] + [thresholds[k] for k in
                                                          THRESHOLD_NAMES[1:]])
    return (scores <= limits[:, None]).all(axis=0)
