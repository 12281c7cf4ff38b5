"""Answers unchanged: the compound oracle re-run on the golden sets gives the recorded answers.

The golden files (``tests/data/golden/compound_*.npz``, written by ``python -m
tests.golden.record``) pin today's :func:`impactnet.models.compound.compound_answer` on seeded
poses: container castings at detail 1 and 2 (apertures), a spreader's twistlocks of 8 to 256
sides landing on a 40 ft container, and a container along the cell guide, each with touching,
separated and deep poses. Every pose is re-solved and judged by
:mod:`tests.golden.compound_compare`: part contacts as sets keyed by (part_a, part_b), each
judged by the rule of :mod:`tests.golden.compare`, and the summary; borderline poses are counted
by cause (printed; ``pytest -s`` or ``-rP`` shows the counts).
"""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.compound import compound_answer
from tests.golden import compare, compound_compare, rule, store
from tests.golden.compound_sets import SETS, bodies, fingerprint

POSE_KEYS = ("position_a", "quaternion_a", "position_b", "quaternion_b")


def solved(name: str, golden: dict):
    """The bodies of set ``name`` (checked against the recorded fingerprints) and the
    oracle's answer on the recorded poses."""
    parts_a, parts_b = bodies(name)
    assert [fingerprint(parts_a), fingerprint(parts_b)] == golden["fingerprints"].tolist(), (
        f"compound_{name}: the bodies changed since the recording; the golden answers hold for "
        "the recorded bodies only")
    a, qa, b, qb = (golden[k] for k in POSE_KEYS)
    return compound_answer(parts_a, a, qa, parts_b, b, qb)


@pytest.fixture(scope="module", params=list(SETS))
def golden(request):
    return request.param, store.load(f"compound_{request.param}")


def test_the_golden_compound_set_is_answered_as_recorded(golden):
    name, data = golden
    verdict = compound_compare.judge_compound(data, solved(name, data))
    counts = rule.cause_counts(verdict.causes)
    parts = rule.cause_counts(data["part_causes"].astype(np.int64))
    ill = int(((verdict.causes == 0) & (data["pose_sensitivity"] > rule.MATCH_TOL_REL)).sum())
    print(f"\ncompound_{name}: {len(verdict.failed)} poses, {len(data['part_pose'])} part "
          f"contacts; borderline poses by cause {counts}; part contacts by cause {parts}; "
          f"poses differing but explained: {int(verdict.relaxed.sum())}; ill-conditioned clear "
          f"poses {ill}")
    labels = data["families"][data["family"]]
    lines = [f"pose {p} ({labels[p]}): {text}"
             + compare.ill_conditioned(data["pose_sensitivity"], p)
             for p, text in verdict.reasons[:10]]
    assert not verdict.failed.any(), (f"compound_{name}: {int(verdict.failed.sum())} poses "
                                      "differ from the golden answers:\n" + "\n".join(lines))


def test_a_changed_compound_answer_fails_the_rule():
    """The rule is not vacuous: a moved part contact point, a lost part contact and a changed
    summary depth on clear poses are each caught."""
    data = store.load("compound_castings")
    answer = solved("castings", data)
    clear = np.flatnonzero((data["pose_causes"] == 0) & (np.diff(data["offsets"]) > 1))[:3]
    changed = dict(data)
    first = data["offsets"][clear]
    changed["part_point"] = data["part_point"].copy()
    changed["part_point"][first[0], 0] += 1e-10
    keep = np.ones(len(data["part_pose"]), bool)
    keep[first[1]] = False
    for name in [k for k in data if k.startswith("part_") and len(data[k]) == len(keep)]:
        changed[name] = changed[name][keep]
    count = data["part_manifold_count"].astype(int)
    slots = np.repeat(keep, count)
    changed["part_manifold_points"] = data["part_manifold_points"][slots]
    changed["part_manifold_depths"] = data["part_manifold_depths"][slots]
    changed["summary_depth"] = data["summary_depth"].copy()
    changed["summary_depth"][clear[2]] += 1e-9
    verdict = compound_compare.judge_compound(changed, answer)
    assert np.flatnonzero(verdict.failed).tolist() == sorted(clear.tolist())


def test_a_borderline_part_contact_may_come_and_go():
    """A part contact recorded as borderline for contact / no contact may be missing from a
    re-run; the same contact on a clear pose may not. A clip-borderline contact may change its
    manifold."""
    data = store.load("compound_apertures")
    answer = solved("apertures", data)
    clip = np.flatnonzero(data["part_causes"] & rule.CAUSE_BIT["clip"])[0]
    found = answer.parts.contacts
    rows = np.flatnonzero((answer.parts.pose == data["part_pose"][clip])
                          & (answer.parts.part_a == data["part_a"][clip])
                          & (answer.parts.part_b == data["part_b"][clip]))
    found.manifold_count[rows] = 1
    verdict = compound_compare.judge_compound(data, answer)
    assert not verdict.failed.any() and verdict.relaxed[data["part_pose"][clip]]
    dropped = dict(data)
    keep = np.ones(len(data["part_pose"]), bool)
    keep[0] = False  # the first part contact disappears from the record
    pose = int(data["part_pose"][0])
    for name in [k for k in data if k.startswith("part_") and len(data[k]) == len(keep)]:
        dropped[name] = data[name][keep]
    slots = np.repeat(keep, data["part_manifold_count"].astype(int))
    for name in ("part_manifold_points", "part_manifold_depths"):
        dropped[name] = data[name][slots]
    answer = solved("apertures", data)
    assert np.flatnonzero(compound_compare.judge_compound(dropped, answer).failed) == [pose]
    for name in ("absent_pose", "absent_a", "absent_b"):
        column = {"absent_pose": "part_pose", "absent_a": "part_a", "absent_b": "part_b"}[name]
        dropped[name] = data[column][:1]
    dropped["absent_causes"] = np.array([rule.CAUSE_BIT["contact"]], np.uint8)
    dropped["pose_causes"] = data["pose_causes"].copy()
    dropped["pose_causes"][pose] |= rule.CAUSE_BIT["contact"]
    assert not compound_compare.judge_compound(dropped, answer).failed.any()
