"""The smoke test that a learned bundle passes before it serves (at startup, on every reload).

For each pair of the bundle, :func:`smoke_poses` draws ``n`` first-contact poses from a fixed seed
(the same bundle always meets the same poses): A anywhere near the origin in a uniform random
orientation, B in a uniform random orientation relative to A, coming in along a uniform random
direction to first touch (:func:`impactnet.models.geometry.approach.touching_distance`, exact), then
pushed in by a depth drawn from the pair's trained range. Every fourth row is given in the swapped
order (B, A), which the predictors solve swapped and flip back. Then:

1. Every learned mode that the new state serves answers the whole batch, and its first row
   alone (the N = 1 path), through the service's own predictor objects: no exception, the
   right shapes, finite numbers, unit normals, confidences in [0, 1].
2. The committee agrees with the exact solver within :class:`SmokeLimits`: the share of rows whose
   colliding flag agrees, and the median normal angle error and median point error (a fraction of
   the pair's length scale L, the sum of the two boxes' largest half-extents, as in the features) on
   the rows whose point the experts give: both call the row colliding, the committee answered it,
   and the region labeller's unclipped point is not already exact
   (:func:`impactnet.models.learned.region_label.unclipped_points`). On the other rows the
   committee's answer is the exact labeller's by construction, so they would hide a broken network.
   The same figures are reported for ``single`` (all colliding rows) and ``auto`` without a bound
   (``single`` is the paper's coarse design; ``auto`` replaces the committee's unsure rows by exact
   answers).

The bounds are loose on purpose: they catch a bundle that is broken, not one that is a little
less accurate (accuracy is measured by ``impactnet evaluate`` on held-out data). A failure
raises :class:`SmokeTestFailed` naming the pair, the mode and the figure.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.box.exact import box_box
from impactnet.models.contacts import Contacts
from impactnet.models.geometry.approach import touching_distance
from impactnet.models.geometry.rotations import (
    quaternion_multiply,
    quaternion_to_matrix,
    random_quaternions,
)
from impactnet.models.learned.bundle_loader import Bundle
from impactnet.models.learned.region_label import unclipped_points
from impactnet.models.metrics import angle_deg
from impactnet.service.predictors import pair_args

#: Seed of the smoke poses (fixed: a bundle's smoke result is reproducible).
SMOKE_SEED = 20240601
#: Normals whose length is off 1 by more than this (dimensionless) count as broken.
UNIT_TOL = 1e-3


class SmokeTestFailed(RuntimeError):
    """A bundle failed the smoke test; the message names the pair, mode and figure."""


@dataclass(frozen=True)
class SmokeLimits:
    """Loose bounds of the agreement with the exact solver (see the module docstring)."""

    colliding_agreement_min: float = 0.8  # share of rows whose colliding flag equals exact's
    normal_median_max_deg: float = 15.0  # median angle between normals, degrees
    point_median_max: float = 0.2  # median point distance, fraction of the length scale L


def smoke_poses(size_a, size_b, n: int, depth_fraction, seed: int = SMOKE_SEED) -> tuple:
    """``n`` first-contact poses of one pair (module docstring): the six columns of a
    predictor call (``box_box``'s signature), (n, 3) or (n, 4) each."""
    rng = np.random.default_rng(seed)
    size_a, size_b = np.asarray(size_a, np.float64), np.asarray(size_b, np.float64)
    q_a = random_quaternions(n, rng)
    q_ab = random_quaternions(n, rng)
    direction = rng.standard_normal((n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    touch = touching_distance(size_a, size_b, quaternion_to_matrix(q_ab), direction)
    edge = float(min(size_a.min(), size_b.min()))
    depth = rng.uniform(depth_fraction[0], depth_fraction[1], n) * edge
    position_a = rng.uniform(-10.0, 10.0, (n, 3))
    offset = np.einsum("nij,nj->ni", quaternion_to_matrix(q_a), direction)
    position_b = position_a + (touch - depth)[:, None] * offset
    q_b = quaternion_multiply(q_a, q_ab)
    sizes_a, sizes_b = np.tile(size_a, (n, 1)), np.tile(size_b, (n, 1))
    swap = np.arange(n) % 4 == 3
    columns = [sizes_a, position_a, q_a, sizes_b, position_b, q_b]
    for first, second in ((0, 3), (1, 4), (2, 5)):
        a, b = columns[first], columns[second]
        columns[first] = np.where(swap[:, None], b, a)
        columns[second] = np.where(swap[:, None], a, b)
    return tuple(columns)


def _check_answer(contacts: Contacts, n: int, where: str) -> None:
    """Shapes, finite values, unit normals, confidences in [0, 1]."""
    if len(contacts) != n or contacts.point.shape != (n, 3) or contacts.normal.shape != (n, 3):
        raise SmokeTestFailed(f"{where}: answered {len(contacts)} rows for {n}")
    finite = (np.isfinite(contacts.point).all() and np.isfinite(contacts.normal).all()
              and np.isfinite(contacts.depth).all() and np.isfinite(contacts.confidence).all())
    if not finite:
        raise SmokeTestFailed(f"{where}: non-finite values (NaN or infinity) in the answer")
    length = np.linalg.norm(contacts.normal, axis=1)
    if np.abs(length - 1.0).max() > UNIT_TOL:
        raise SmokeTestFailed(f"{where}: normals are not unit vectors")
    if contacts.confidence.min() < 0.0 or contacts.confidence.max() > 1.0:
        raise SmokeTestFailed(f"{where}: confidence outside [0, 1]")


def agreement(contacts: Contacts, exact: Contacts, scale: float,
              learned: np.ndarray | None = None) -> dict:
    """Agreement of ``contacts`` with the exact answers (see :class:`SmokeLimits`); the
    errors on the rows both call colliding, only those of ``learned`` (n,) bool if given."""
    both = contacts.colliding & exact.colliding
    if learned is not None:
        both &= learned
    angle = angle_deg(contacts.normal[both], exact.normal[both])
    point = np.linalg.norm(contacts.point[both] - exact.point[both], axis=1) / scale
    return {"colliding_agreement": float(np.mean(contacts.colliding == exact.colliding)),
            "normal_median_deg": float(np.median(angle)) if angle.size else 0.0,
            "point_median": float(np.median(point)) if point.size else 0.0,
            "compared": int(both.sum())}


def _check_agreement(figures: dict, limits: SmokeLimits, where: str) -> None:
    if figures["colliding_agreement"] < limits.colliding_agreement_min:
        raise SmokeTestFailed(
            f"{where}: colliding flag agrees with exact on {figures['colliding_agreement']:.0%}"
            f" of the rows (minimum {limits.colliding_agreement_min:.0%})")
    if figures["normal_median_deg"] > limits.normal_median_max_deg:
        raise SmokeTestFailed(
            f"{where}: median normal error {figures['normal_median_deg']:.3g} deg against exact "
            f"(maximum {limits.normal_median_max_deg:g})")
    if figures["point_median"] > limits.point_median_max:
        raise SmokeTestFailed(
            f"{where}: median point error {figures['point_median']:.3g} L against exact "
            f"(maximum {limits.point_median_max:g} L)")


def smoke_test(predictors: dict, bundle: Bundle, n: int,
               limits: SmokeLimits | None = None) -> dict:
    """Run the smoke test of ``bundle`` on the learned ``predictors`` (mode -> predictor of
    the state being built); returns the figures per pair and mode, raises SmokeTestFailed."""
    limits = limits or SmokeLimits()
    learned = {m: p for m, p in predictors.items() if m != "exact"}
    report: dict = {"poses_per_pair": n, "limits": limits.__dict__.copy(), "pairs": {}}
    for key, models in bundle.pairs.items():
        pairs = smoke_poses(models.size_a, models.size_b, n, models.depth_fraction)
        exact = box_box(*pairs)
        scale = 0.5 * (max(models.size_a) + max(models.size_b))  # L, metres
        expert_rows = ~unclipped_points(*pairs)[1]
        figures = {}
        for mode, predictor in learned.items():
            if mode != "auto" and not _has_models(models, mode):
                continue  # a strict mode without models for this pair answers 422 for it
            where = f"pair {key}, mode {mode}"
            try:
                batch = predictor(*pair_args(pairs))
                one = predictor(*pair_args(tuple(c[:1] for c in pairs)))
            except Exception as exc:  # noqa: BLE001 - any failure is the bundle's
                raise SmokeTestFailed(f"{where}: {type(exc).__name__}: {exc}") from exc
            _check_answer(batch, n, where)
            _check_answer(one, 1, where + " (one pair)")
            rows = None if mode == "single" else expert_rows & (batch.predictor == "committee")
            figures[mode] = agreement(batch, exact, scale, rows)
            if mode == "committee":
                _check_agreement(figures[mode], limits, where)
        report["pairs"][key] = figures
    return report


def _has_models(models, mode: str) -> bool:
    return models.single is not None if mode == "single" else models.labeller is not None
