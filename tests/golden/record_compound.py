"""Recording of the compound golden files (see :mod:`tests.golden.record`; not a test module).

Per set: the bodies' poses, :func:`impactnet.models.compound.compound_answer`'s summary and part
contacts, the margins of every part contact (:mod:`tests.golden.compound_pairs`) with the
filter's (:mod:`tests.golden.compound_filter`), the borderline part pairs absent from the
answer (a contact or filter decision could add them), the summary's margin per pose and the
bodies' fingerprints. The filter's margins need each near pair's raw part contact: the recorder
asks today's part solvers (``box_box``, ``convex_contacts``) for them.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box.exact import box_box
from impactnet.models.compound import compound_answer
from impactnet.models.compound.convex_contact import convex_contacts
from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart
from tests.golden import compound_sets as sets
from tests.golden import rule, store
from tests.golden.compound_filter import Body, filter_value, summary_margins
from tests.golden.compound_pairs import body_poses, pair_margins
from tests.golden.record_box import ModelMismatch
from tests.golden.sensitivity import compound_sensitivity

POSE_KEYS = ("position_a", "quaternion_a", "position_b", "quaternion_b")
SUMMARY_FIELDS = ("colliding", "normal", "depth", "point", "cluster_size")


def envelope(parts_a, parts_b) -> float:
    """The bodies' scale (metres): the largest edge of either body's bounding box."""
    points = [np.concatenate([p.vertices() for p in parts]) for parts in (parts_a, parts_b)]
    return float(max(np.ptp(v, axis=0).max() for v in points))


def raw_contacts(parts_a, parts_b, poses, pairs) -> dict:
    """Today's part solvers' answers (before the filter) for the near pairs, as arrays."""
    pos_a, q_a, rot_a, pos_b, q_b, rot_b = poses
    k = len(pairs.pose)
    out = {"colliding": np.zeros(k, bool), "normal": np.zeros((k, 3)),
           "manifold_points": np.zeros((k, 8, 3)), "manifold_depths": np.zeros((k, 8)),
           "manifold_count": np.zeros(k, int)}
    groups = {}
    for r, (a, b) in enumerate(zip(pairs.part_a, pairs.part_b)):
        groups.setdefault((int(a), int(b)), []).append(r)
    for (a, b), rows in groups.items():
        rows, at = np.array(rows), pairs.pose[rows]
        if isinstance(parts_a[a], BoxPart) and isinstance(parts_b[b], BoxPart):
            found = box_box(parts_a[a].size, pos_a[at] + rot_a[at] @ np.array(parts_a[a].centre),
                            q_a[at], parts_b[b].size,
                            pos_b[at] + rot_b[at] @ np.array(parts_b[b].centre), q_b[at])
        else:
            found = convex_contacts(hull_of(parts_a[a]), hull_of(parts_b[b]), pos_a[at],
                                    rot_a[at], pos_b[at], rot_b[at])
        for name in out:
            out[name][rows] = getattr(found, name)
    return out


def filter_causes(parts_a, parts_b, poses, pairs, raw, scale_m):
    """(k,) the filter's borderline bit of the near pairs and (k,) whether it hides them."""
    body_a, body_b = Body(parts_a), Body(parts_b)
    bits, hidden = np.zeros(len(pairs.pose), np.int64), np.zeros(len(pairs.pose), bool)
    for r in np.flatnonzero(raw["colliding"]):
        count = raw["manifold_count"][r]
        contact = {"normal": raw["normal"][r], "manifold_points": raw["manifold_points"][r, :count],
                   "manifold_depths": raw["manifold_depths"][r, :count]}
        value = filter_value(contact, body_a, body_b, poses, pairs.pose[r], pairs.part_a[r],
                             pairs.part_b[r])
        bits[r] = rule.CAUSE_BIT["filter"] if abs(value) < rule.DECISION_TOL_REL * scale_m else 0
        hidden[r] = value < 0.0
    return bits, hidden


def check_model(name, pairs, hidden, present, answer_rows, answer) -> None:
    """Raise :class:`ModelMismatch` where the decisions redone here differ from the oracle's
    on a pair that is not borderline for them (presence, reference feature, type)."""
    bit = rule.CAUSE_BIT
    clear = (pairs.causes & (bit["contact"] | bit["filter"])) == 0
    expected = pairs.colliding & ~hidden
    wrong = {"presence": np.flatnonzero(clear & (expected != present))}
    rows = np.flatnonzero(present & ((pairs.causes & (bit["contact"] | bit["tie"])) == 0))
    c = answer.parts.contacts
    found = np.stack([c.feature_a[answer_rows[rows]], c.feature_b[answer_rows[rows]]], axis=1)
    predicted = pairs.features[rows]
    wrong["feature"] = rows[((predicted != found) & (predicted != -2)).any(axis=1)]
    rows = rows[(pairs.causes[rows] & bit["feature"]) == 0]
    code = c.contact_type_code[answer_rows[rows]]
    wrong["type"] = rows[(pairs.type_code[rows] >= 0) & (pairs.type_code[rows] != code)]
    bad = {k: v[:10].tolist() for k, v in wrong.items() if len(v)}
    if bad:
        raise ModelMismatch(f"compound set {name!r}: decisions differ from the oracle's on "
                            f"clear pairs {bad}")


def _ragged_or(values: np.ndarray, group: np.ndarray, n: int) -> np.ndarray:
    """(n,) bitwise OR of ``values`` (k,) by ``group`` (k,) in 0..n-1."""
    out = np.zeros(n, np.int64)
    np.bitwise_or.at(out, group, values.astype(np.int64))
    return out


def _matched(pairs, answer, n_a: int, n_b: int):
    """(answer row of each near pair or -1, near pair of each answer row)."""
    parts = answer.parts
    key = (pairs.pose * n_a + pairs.part_a) * n_b + pairs.part_b
    answer_key = (parts.pose * n_a + parts.part_a.astype(np.int64)) * n_b + parts.part_b
    where = {int(k): r for r, k in enumerate(key)}
    missing = [int(k) for k in answer_key if int(k) not in where]
    if missing:
        raise ModelMismatch(f"part contacts outside the near pairs: keys {missing[:10]}")
    pair_of_answer = np.array([where[int(k)] for k in answer_key], np.int64)
    answer_rows = np.full(len(key), -1)
    answer_rows[pair_of_answer] = np.arange(len(answer_key))
    return answer_rows, pair_of_answer


def record_compound_set(name: str, note: str, folder=store.GOLDEN_DIR) -> dict:
    """Build, solve and store one compound set; returns its summary (poses, part contacts,
    borderline poses by cause, file size)."""
    parts_a, parts_b = sets.bodies(name)
    data = sets.compound_set(name)
    inputs = [np.ascontiguousarray(data[k], np.float64) for k in POSE_KEYS]
    answer = compound_answer(parts_a, inputs[0], inputs[1], parts_b, inputs[2], inputs[3])
    poses = body_poses(*inputs)
    pairs = pair_margins(parts_a, parts_b, poses)
    scale_m = envelope(parts_a, parts_b)
    bits, hidden = filter_causes(parts_a, parts_b, poses, pairs,
                                 raw_contacts(parts_a, parts_b, poses, pairs), scale_m)
    pairs.causes = pairs.causes | bits
    answer_rows, pair_of_answer = _matched(pairs, answer, len(parts_a), len(parts_b))
    check_model(name, pairs, hidden, answer_rows >= 0, answer_rows, answer)
    n, c = len(inputs[0]), answer.parts.contacts
    presence = rule.CAUSE_BIT["contact"] | rule.CAUSE_BIT["filter"]
    absent = np.flatnonzero((answer_rows < 0) & ((pairs.causes & presence) != 0))
    margin = summary_margins(answer.parts.offsets, c.depth, c.normal, scale_m)
    pose_causes = (np.where(margin < rule.DECISION_TOL_ANGLE, rule.CAUSE_BIT["summary"], 0)
                   | _ragged_or(pairs.causes[pair_of_answer], answer.parts.pose, n)
                   | _ragged_or(pairs.causes[absent], pairs.pose[absent], n))
    arrays = dict(zip(POSE_KEYS, inputs))
    arrays.update(family=data["family"], families=data["families"], note=np.array(note),
                  margin_names=np.array(rule.MARGIN_NAMES), envelope=np.array(scale_m),
                  bodies=np.array([sets.body_label(b) for b in sets.SETS[name][:2]]),
                  fingerprints=np.array([sets.fingerprint(parts_a), sets.fingerprint(parts_b)]),
                  offsets=answer.parts.offsets, part_pose=answer.parts.pose.astype(np.int32),
                  part_a=answer.parts.part_a, part_b=answer.parts.part_b,
                  part_scale=pairs.scale[pair_of_answer], pose_causes=pose_causes.astype(np.uint8),
                  summary_margin=margin.astype(np.float32), absent_pose=pairs.pose[absent],
                  absent_a=pairs.part_a[absent], absent_b=pairs.part_b[absent],
                  absent_causes=pairs.causes[absent].astype(np.uint8))
    arrays.update({f"summary_{k}": np.asarray(getattr(answer.summary, k)) for k in SUMMARY_FIELDS})
    arrays.update(store.pack_contacts(c, "part_"))
    rows = type("Rows", (), {k: getattr(pairs, k)[pair_of_answer] for k in store.RULE_FIELDS})
    arrays.update(store.pack_rule(rows, "part_"))
    part_sens, pose_sens, flips = compound_sensitivity(parts_a, parts_b, dict(zip(POSE_KEYS,
                                                                                  inputs)),
                                                       answer, scale_m)
    arrays.update(part_sensitivity=part_sens.astype(np.float32),
                  pose_sensitivity=pose_sens.astype(np.float32))
    path = store.save(f"compound_{name}", arrays, folder)
    clear = pose_causes == 0
    return {"rows": n, "part_contacts": len(c.depth), "causes": rule.cause_counts(pose_causes),
            "part_causes": rule.cause_counts(pairs.causes[pair_of_answer]),
            "ill_conditioned": int((clear & (pose_sens > rule.MATCH_TOL_REL)).sum()),
            "probe_flips_on_clear": int((clear & flips).sum()), "bytes": path.stat().st_size}
