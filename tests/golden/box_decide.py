"""The box solver's contact axis by its tie rule, with every decision's margin (not a test
module).

:func:`decide` follows :func:`impactnet.models.box.sat.choose_axis` and rule 3 of
:func:`impactnet.models.box.exact.contact_axes` on the overlaps of :mod:`tests.golden.box_axes`
and records, per row, the smallest distance of a compared quantity from its threshold (metres)
and the *tied set*: the axes that a decision within :data:`tests.golden.rule.DECISION_TOL_REL`
of its threshold could hand the answer to.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.golden import rule
from tests.golden.box_axes import Local, band_products, edge_parameters, overlaps


class Tally:
    """The smallest margin (n,) of a kind and the axes (bitmask over the 15) a borderline
    decision ties; ``tol`` (n,) is the borderline threshold in the margins' units."""

    def __init__(self, tol: np.ndarray):
        self.tol, self.margin = tol, np.full(len(tol), np.inf)
        self.tied = np.zeros(len(tol), np.int64)

    def add(self, margin: np.ndarray, *axes: np.ndarray) -> None:
        """Fold in a margin (n,) (NaN: no decision) whose flip hands the answer between
        ``axes`` (each (n,) axis ids)."""
        margin = np.where(np.isnan(margin), np.inf, margin)
        self.margin = np.minimum(self.margin, margin)
        bits = np.zeros(len(margin), np.int64)
        for axis in axes:
            bits |= np.left_shift(1, np.asarray(axis, np.int64))
        self.tied |= np.where(margin < self.tol, bits, 0)


@dataclass
class Decided:
    """The rule's answer and margins for N pairs (lengths in metres)."""

    colliding: np.ndarray  # (n,) bool
    axis: np.ndarray  # (n,) the contact axis (separated: the most separating one)
    sat_depth: np.ndarray  # (n,) overlap along the contact axis, clamped at 0
    margins: dict  # name -> (n,) margin, metres or dimensionless (tests.golden.rule)
    tied: np.ndarray  # (n,) bitmask over the 15 axes (the answer's own axis included)
    tie_width: np.ndarray  # (n,) metres: largest depth change between tied answers


def _rule_one(pose, tally_unit, cross, raw, skipped, sines, face_axis, face_min):
    """Rule 1 (the angle band): which cross axes are near the face axis; margins of the
    cross axes that could change the answer (shallower than the face)."""
    product = band_products(pose.r, face_axis)
    near = np.nan_to_num(product, nan=-1.0) >= rule.FACE_AXIS_COS_TOL * sines
    relevant = np.isfinite(product) & ~skipped & (raw < face_min[:, None])
    gap = np.where(relevant, np.abs(product - rule.FACE_AXIS_COS_TOL * sines), np.inf)
    for c in range(9):
        tally_unit.add(gap[:, c], np.full(len(face_axis), 6 + c), face_axis)
    return near


def _rule_two(tally, cross, near, face_axis, face_min, gain):
    """Rule 2 (depth gain) and equal cross axes: (use_cross (n,), the cross axis id (n,))."""
    eligible = np.where(near, np.inf, cross)
    order = np.argsort(eligible, axis=1, kind="stable")
    best, runner = (np.take_along_axis(eligible, order[:, k:k + 1], axis=1)[:, 0]
                    for k in (0, 1))
    face_bar = np.minimum(face_min, np.where(near, cross, np.inf).min(axis=1))
    use_cross = best < face_bar - gain
    finite = np.isfinite(best)
    tally.add(np.where(finite, np.abs(best - face_bar + gain), np.inf), order[:, 0] + 6,
              face_axis)
    tally.add(np.where(use_cross, runner - best, np.inf), order[:, 0] + 6, order[:, 1] + 6)
    return use_cross, order[:, 0] + 6


def _rule_three(pose, tally, units, axis, face_axis, rows):
    """Rule 3 on ``rows`` (cross-axis winners): (inside (k,), edge-side margins (k,))."""
    u = units[rows, axis[rows] - 6]
    normal = u * np.where(np.einsum("ni,ni->n", u, pose.t[rows]) >= 0.0, 1.0, -1.0)[:, None]
    sub = Local(*(x[rows] for x in (pose.ha, pose.hb, pose.r, pose.t, pose.scale,
                                    pose.reach)))
    s_free, t_free, reach_a, reach_b, sides = edge_parameters(sub, normal, axis[rows])
    slack = rule.EDGE_INSIDE_TOL_REL * sub.scale
    inside = (np.abs(s_free) <= reach_a + slack) & (np.abs(t_free) <= reach_b + slack)
    margin = np.full(len(axis), np.inf)
    margin[rows] = np.minimum(np.abs(reach_a + slack - np.abs(s_free)),
                              np.abs(reach_b + slack - np.abs(t_free)))
    tally.add(margin, axis, face_axis)
    return inside, sides


def _projections(pose: Local, units) -> np.ndarray:
    """``u . t`` along the 15 axes (n, 15): the normal's orientation (metres)."""
    tb = np.einsum("nij,ni->nj", pose.r, pose.t)
    return np.concatenate([pose.t, tb, np.einsum("nci,ni->nc", units, pose.t)], axis=1)


def decide(pose: Local) -> Decided:
    """The contact axis of N pairs by the solver's rule, with its margins (module docstring)."""
    n, scale = len(pose.scale), pose.scale
    tol = rule.DECISION_TOL_REL * pose.reach * scale
    tally, tally_unit = Tally(tol), Tally(np.full(n, rule.DECISION_TOL_UNIT))
    over, skipped, skew, units, sines = overlaps(pose)
    face, raw = over[:, :6], over[:, 6:]
    cross = np.where(skipped, np.inf, raw)
    face_min = face.min(axis=1)
    in_band = face <= (face_min + rule.TIE_TOL_REL * scale)[:, None]
    face_axis = np.argmax(in_band, axis=1)
    band_gap = np.abs(face - (face_min + rule.TIE_TOL_REL * scale)[:, None])
    members = [np.where(in_band[:, g], g, face_axis) for g in range(6)]  # who may take over
    for f in range(6):
        own = f == np.argmin(face, axis=1)  # the least overlap is always in its own band
        tally.add(np.where((f <= face_axis) & ~own, band_gap[:, f], np.inf), np.full(n, f),
                  *members)
    near = _rule_one(pose, tally_unit, cross, raw, skipped, sines, face_axis, face_min)
    use_cross, cross_axis = _rule_two(tally, cross, near, face_axis, face_min,
                                      rule.DEPTH_GAIN_TOL_REL * scale)
    least = np.minimum(face_min, cross.min(axis=1))
    colliding = least >= -rule.CONTACT_TOL_REL * scale
    contact = np.abs(least + rule.CONTACT_TOL_REL * scale)
    rows = np.flatnonzero(colliding & use_cross)
    inside, sides = _rule_three(pose, tally, units, cross_axis, face_axis, rows)
    axis = np.where(colliding, face_axis, 0)
    axis[rows[inside]] = cross_axis[rows[inside]]
    everything = np.concatenate([face, cross], axis=1)
    order = np.argsort(everything, axis=1, kind="stable")
    lo, runner = (np.take_along_axis(everything, order[:, k:k + 1], axis=1)[:, 0] for k in (0, 1))
    axis = np.where(colliding, axis, order[:, 0])
    tally.add(np.where(colliding, np.inf, runner - lo), order[:, 0], order[:, 1])
    projection = np.abs(np.take_along_axis(_projections(pose, units), axis[:, None], 1)[:, 0])
    tally.add(np.where(colliding, projection, np.inf), axis)
    relevant = ~np.isinf(raw) & (raw < np.maximum(face_min, 0.0)[:, None])
    skew_gap = np.where(relevant, np.abs(skew - rule.EDGE_SKEW_TOL_REL * scale[:, None]), np.inf)
    for c in range(9):
        tally.add(skew_gap[:, c], np.full(n, 6 + c), axis)
    edge_sides = np.full(n, np.inf)
    edge_sides[rows[inside]] = sides[inside]
    chosen = np.take_along_axis(over, axis[:, None], axis=1)[:, 0]
    sat_depth = np.where(colliding, np.maximum(chosen, 0.0), 0.0)
    tied = tally.tied | tally_unit.tied
    depths = np.nan_to_num(np.maximum(over, 0.0), posinf=0.0)
    spread = np.where((tied[:, None] >> np.arange(15)) & 1, np.abs(depths - sat_depth[:, None]),
                      0.0).max(axis=1)
    width = spread + (rule.DEPTH_GAIN_TOL_REL + rule.REGION_DEPTH_TOL_REL) * scale
    tied = np.where(tied != 0, tied | np.left_shift(1, axis.astype(np.int64)), 0)
    margins = {"contact": contact, "tie": tally.margin, "band": tally_unit.margin,
               "feature_unit": edge_sides}
    return Decided(colliding, axis, sat_depth, margins, tied, width)
