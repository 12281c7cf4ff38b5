"""The comparison rule applied to compound answers, pose by pose (not a test module).

Per pose, the part contacts compare as sets keyed by (part_a, part_b): a key present on one
side only is accepted where that part pair is borderline for contact / no contact or for the
covered-surface filter (recorded on the contact, or in the file's ``absent_*`` table); the
contacts of common keys are judged row by row by :func:`tests.golden.compare.judge` with the
bodies' envelope as the scale. The summary must match exactly on a pose without a borderline
cause, or one whose causes change no summary input (feature, clip); a tie, region or summary
cause lets the normal, point and cluster size move and the depth by the pose's largest tie or
region width; a contact or filter cause lets everything move.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.golden import compare, rule, store

SUMMARY_FIELDS = ("colliding", "depth", "normal", "point", "cluster_size")
#: Bits of the key of a part contact: pose << 32 | part_a << 16 | part_b.
_SHIFT_POSE, _SHIFT_A = 32, 16


@dataclass
class CompoundVerdict:
    """The rule's verdict on N poses."""

    failed: np.ndarray  # (n,) bool: a difference no recorded cause explains
    relaxed: np.ndarray  # (n,) bool: differed, and a borderline cause explains it
    causes: np.ndarray  # (n,) int: the recorded causes of each pose
    reasons: list  # (pose, text) of the failures


def keys(pose, part_a, part_b) -> np.ndarray:
    """The int64 key of each part contact."""
    return ((np.asarray(pose, np.int64) << _SHIFT_POSE) | (np.asarray(part_a, np.int64) << _SHIFT_A)
            | np.asarray(part_b, np.int64))


def _summary_bad(golden: dict, summary, scale: float) -> np.ndarray:
    """(n, 5) bool: which summary fields differ beyond the clear-row tolerances."""
    n = len(golden["summary_depth"])
    point, found_point = golden["summary_point"], np.asarray(summary.point)
    tol = compare.coordinate_tol(point, np.full(n, scale))
    return np.stack([
        golden["summary_colliding"] != summary.colliding,
        ~(np.abs(golden["summary_depth"] - summary.depth) <= rule.MATCH_TOL_REL * scale),
        ~(compare.normal_angle(golden["summary_normal"], summary.normal) <= rule.NORMAL_TOL_RAD)
        & golden["summary_colliding"],
        ~(np.abs(point - found_point) <= tol).all(axis=1),
        golden["summary_cluster_size"] != summary.cluster_size], axis=1)


def _pose_widths(golden: dict, n: int) -> np.ndarray:
    """(n,) metres: the largest depth change a tie or region cause allows in each pose."""
    width = (golden["part_tie_width"] + 2.0 * rule.REGION_DEPTH_TOL_REL) * golden["part_scale"]
    out = np.zeros(n)
    np.maximum.at(out, golden["part_pose"].astype(np.int64), width)
    return out


def _key_faults(golden: dict, found_keys: np.ndarray, recorded_keys: np.ndarray):
    """(pose, text) of keys present on one side only without a contact or filter cause."""
    either = rule.CAUSE_BIT["contact"] | rule.CAUSE_BIT["filter"]
    excused = set(keys(golden["absent_pose"], golden["absent_a"], golden["absent_b"]).tolist())
    loose = (golden["part_causes"].astype(np.int64) & either) != 0
    excused |= set(recorded_keys[loose].tolist())
    faults = []
    for key in np.setxor1d(recorded_keys, found_keys):
        if int(key) not in excused:
            side = "lost" if key in recorded_keys else "new"
            pair = (int(key) >> _SHIFT_A) & 0xFFFF, int(key) & 0xFFFF
            faults.append((int(key) >> _SHIFT_POSE, f"{side} part contact {pair}"))
    return faults


def judge_compound(golden: dict, answer) -> CompoundVerdict:
    """Apply the rule (module docstring) to a re-computed ``CompoundAnswer`` of a golden set."""
    n = len(golden["summary_depth"])
    scale = float(golden["envelope"])
    recorded_keys = keys(golden["part_pose"], golden["part_a"], golden["part_b"])
    parts = answer.parts
    found_keys = keys(parts.pose, parts.part_a, parts.part_b)
    _, ir, jf = np.intersect1d(recorded_keys, found_keys, return_indices=True)
    recorded = {k: v[ir] for k, v in store.unpack_contacts(golden, "part_").items()}
    found = {k: np.asarray(v)[jf] for k, v in parts.contacts.arrays().items()}
    rule_data = {k: golden[f"part_{k}"][ir] for k in ("causes", "tied", "tie_width")}
    rows = compare.judge(recorded, found, rule_data, np.full(len(ir), scale),
                         golden["part_scale"][ir])
    pose_of = golden["part_pose"][ir].astype(np.int64)
    reasons = [(int(pose_of[r]), f"part contact {int(ir[r])} (parts {int(golden['part_a'][ir[r]])}"
                f", {int(golden['part_b'][ir[r]])}): "
                + compare.describe(rows, np.array([r])).split(": ", 1)[1])
               for r in np.flatnonzero(rows.failed)]
    reasons += _key_faults(golden, found_keys, recorded_keys)
    causes = golden["pose_causes"].astype(np.int64)
    bad = _summary_bad(golden, answer.summary, scale)
    bit = rule.CAUSE_BIT
    loose = (causes & (bit["contact"] | bit["filter"])) != 0
    moving = (causes & (bit["tie"] | bit["region"] | bit["summary"])) != 0
    depth_ok = (np.abs(golden["summary_depth"] - answer.summary.depth)
                <= _pose_widths(golden, n) + rule.MATCH_TOL_REL * scale)
    explained = loose | (moving & ~bad[:, 0] & (~bad[:, 1] | depth_ok))
    for p in np.flatnonzero(bad.any(axis=1) & ~explained):
        fields = [SUMMARY_FIELDS[k] for k in np.flatnonzero(bad[p])]
        reasons.append((int(p), f"summary {', '.join(fields)} differ"))
    failed = np.zeros(n, bool)
    failed[[p for p, _ in reasons]] = True
    differed = bad.any(axis=1)
    np.logical_or.at(differed, pose_of, rows.bad.any(axis=1))
    differed[np.right_shift(np.setxor1d(recorded_keys, found_keys), _SHIFT_POSE)] = True
    return CompoundVerdict(failed, differed & ~failed, causes, sorted(reasons))
