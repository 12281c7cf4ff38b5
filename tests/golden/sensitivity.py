"""How far rounding-level changes move each recorded answer: a diagnostic, not a relaxation
(not a test module).

Some answers are ill-conditioned without being near any decision: the centre of pressure of a
contact only microns deep, a clip crossing of two nearly parallel edges, a compound summary's
point (a pressure-weighted mean of contacts metres apart, whose weights change relatively by
rounding / depth). There a re-run that rounds differently moves the answer by more than 1e-12
of the scale although no decision changes. The recorder measures it: the inputs are changed by
:data:`PROBE_ULPS` ulps (sizes and quaternions relatively, positions by that many ulps of the
scale) :data:`PROBE_TRIALS` times, and a row's *sensitivity* is the largest change of its
point, depth, manifold points (x scale) or normal (radians) over the trials where its discrete
answer (type, features, axis, manifold count) stays. The rule stays strict on such rows (a
kernel must keep the NumPy terms' order there); the files keep the sensitivity so that a
failure on an ill-conditioned row says so, and the summary counts those rows.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box.exact import box_box
from impactnet.models.compound import compound_answer
from impactnet.models.domain import SIZE_MAX_M, SIZE_MIN_M
from tests.golden import compare
from tests.models.helpers import KEYS

#: Size of the probe's input changes (ulps): the few ulps a re-run's rounding is worth.
PROBE_ULPS = 4
#: Probe trials per set (independent random changes).
PROBE_TRIALS = 2
_EPS = float(np.finfo(float).eps)
_DISCRETE = ("contact_type_code", "feature_a", "feature_b", "axis", "manifold_count",
             "colliding")


def row_changes(recorded: dict, found: dict, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(change (n,), same (n,)): the largest continuous change (x scale, or radians) and
    whether the discrete answer stayed."""
    same = np.ones(len(scale), bool)
    for name in _DISCRETE:
        same &= recorded[name] == found[name]
    slots = np.arange(recorded["manifold_points"].shape[1])[None, :]
    valid = (slots < recorded["manifold_count"][:, None])[:, :, None]
    manifold = np.where(valid & same[:, None, None],
                        np.abs(recorded["manifold_points"] - found["manifold_points"]), 0.0)
    change = np.maximum.reduce([
        np.abs(recorded["point"] - found["point"]).max(axis=1) / scale,
        np.abs(recorded["depth"] - found["depth"]) / scale,
        manifold.max(axis=(1, 2)) / scale,
        compare.normal_angle(recorded["normal"], found["normal"])])
    return np.where(same, change, 0.0), same


def _changed(values: np.ndarray, rng, relative: bool, scale=None) -> np.ndarray:
    step = PROBE_ULPS * _EPS * rng.uniform(-1.0, 1.0, values.shape)
    return values * (1.0 + step) if relative else values + step * scale[:, None]


def box_sensitivity(inputs: dict, recorded: dict, seed: int = 0):
    """(sensitivity (n,), probe flips (n,) bool) of a box set: its inputs (:data:`KEYS`) and
    the recorded fields (:func:`tests.golden.store.unpack_contacts`)."""
    rng = np.random.default_rng(seed)
    scale = np.maximum(inputs["size_a"].max(axis=1), inputs["size_b"].max(axis=1))
    worst, flips = np.zeros(len(scale)), np.zeros(len(scale), bool)
    for _ in range(PROBE_TRIALS):
        probe = {k: _changed(inputs[k], rng, k[0] != "p", scale) for k in KEYS}
        for k in ("size_a", "size_b"):
            probe[k] = np.clip(probe[k], SIZE_MIN_M, SIZE_MAX_M)
        found = box_box(*(probe[k] for k in KEYS)).arrays()
        change, same = row_changes(recorded, found, scale)
        worst, flips = np.maximum(worst, change), flips | ~same
    return worst, flips


def compound_sensitivity(parts_a, parts_b, inputs: dict, answer, scale: float, seed: int = 0):
    """(part contacts' sensitivity (k,), poses' (n,), probe flips per pose (n,) bool): body B's
    pose changed by the probe; a part contact lost or gained counts as a flip of its pose, the
    summary's point, depth and normal count for the pose."""
    from tests.golden.compound_compare import keys

    rng = np.random.default_rng(seed)
    parts = answer.parts
    recorded_keys = keys(parts.pose, parts.part_a, parts.part_b)
    recorded = parts.contacts.arrays()
    n = len(answer.summary.depth)
    part_worst, pose_worst, flips = np.zeros(len(recorded_keys)), np.zeros(n), np.zeros(n, bool)
    for _ in range(PROBE_TRIALS):
        position = _changed(inputs["position_b"], rng, False, np.full(n, scale))
        quaternion = _changed(inputs["quaternion_b"], rng, True)
        again = compound_answer(parts_a, inputs["position_a"], inputs["quaternion_a"], parts_b,
                                position, quaternion)
        found_keys = keys(again.parts.pose, again.parts.part_a, again.parts.part_b)
        _, ir, jf = np.intersect1d(recorded_keys, found_keys, return_indices=True)
        found = again.parts.contacts.arrays()
        change, same = row_changes({k: v[ir] for k, v in recorded.items()},
                                   {k: v[jf] for k, v in found.items()}, np.full(len(ir), scale))
        part_worst[ir] = np.maximum(part_worst[ir], change)
        np.logical_or.at(flips, parts.pose[ir], ~same)
        flips[np.right_shift(np.setxor1d(recorded_keys, found_keys), 32)] = True
        summary = np.maximum.reduce([
            np.abs(answer.summary.point - again.summary.point).max(axis=1) / scale,
            np.abs(answer.summary.depth - again.summary.depth) / scale,
            compare.normal_angle(answer.summary.normal, again.summary.normal)])
        pose_worst = np.maximum(pose_worst, summary)
    np.maximum.at(pose_worst, parts.pose, part_worst)
    return part_worst, pose_worst, flips
