"""Answers unchanged: the box solver re-run on the golden sets gives the recorded answers.

The golden files (``tests/data/golden/box_*.npz``, written by ``python -m tests.golden.record``)
pin today's answers of :func:`impactnet.models.box.exact.box_box` on seeded sets: the quay
crane scene's first contacts, the stacking families, the paper's Figure 2 case and the fuzz
tests' extremes. Every row is re-solved and judged by the rule of :mod:`tests.golden.compare`:
clear rows match within 1e-12 of the pair's scale (points, depths) and 1e-12 rad (normals)
with equal types and features; borderline rows (a recorded margin below its tolerance,
:mod:`tests.golden.rule`) pass with their cause's relaxation and are counted by cause (printed;
``pytest -s`` or ``-rP`` shows the counts).
"""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from tests.golden import compare, rule, store
from tests.models.helpers import KEYS

SETS = ("scene", "stacking", "figure2", "extremes")


def solved(golden: dict) -> tuple[dict, compare.Verdict]:
    """Re-solve a golden box set; (the recorded fields, the verdict)."""
    inputs = [golden[k] for k in KEYS]
    found = box_box(*inputs).arrays()
    recorded = store.unpack_contacts(golden)
    scale = np.maximum(golden["size_a"].max(axis=1), golden["size_b"].max(axis=1))
    solver_scale = 0.5 * (golden["size_a"].max(axis=1) + golden["size_b"].max(axis=1))
    rule_data = {name: golden[name] for name in ("causes", "tied", "tie_width")}
    return recorded, compare.judge(recorded, found, rule_data, scale, solver_scale)


@pytest.fixture(scope="module", params=SETS)
def golden(request):
    return request.param, store.load(f"box_{request.param}")


def test_the_golden_box_set_is_answered_as_recorded(golden):
    name, data = golden
    _, verdict = solved(data)
    labels = data["families"][data["family"]]
    counts = rule.cause_counts(verdict.causes)
    relaxed = {c: int(((verdict.causes & bit) != 0)[verdict.relaxed].sum())
               for c, bit in rule.CAUSE_BIT.items()}
    ill = int(((verdict.causes == 0) & (data["sensitivity"] > rule.MATCH_TOL_REL)).sum())
    print(f"\nbox_{name}: {len(verdict.failed)} rows; borderline by cause {counts}; "
          f"differing but explained by cause {relaxed}; ill-conditioned clear rows {ill}")
    failed = np.flatnonzero(verdict.failed)
    assert not failed.size, (f"box_{name}: {failed.size} rows differ from the golden answers:\n"
                             + compare.describe(verdict, failed, labels, data["sensitivity"]))


def test_a_changed_answer_fails_the_rule():
    """The rule is not vacuous: a recorded depth moved by 1e-11 of the scale on a clear row,
    a swapped feature, a flipped normal and a lost manifold point are each caught."""
    data = store.load("box_scene")
    recorded, verdict = solved(data)
    clear = np.flatnonzero((verdict.causes == 0) & recorded["colliding"]
                           & (recorded["manifold_count"] > 1))[:4]
    changed = {name: value.copy() for name, value in recorded.items()}
    scale = np.maximum(data["size_a"].max(axis=1), data["size_b"].max(axis=1))
    changed["depth"][clear[0]] += 1e-11 * scale[clear[0]]
    changed["feature_b"][clear[1]] += 1
    changed["normal"][clear[2]] *= -1.0
    changed["manifold_count"][clear[3]] -= 1
    rule_data = {name: data[name] for name in ("causes", "tied", "tie_width")}
    again = compare.judge(recorded, changed, rule_data, scale,
                          0.5 * (data["size_a"].max(axis=1) + data["size_b"].max(axis=1)))
    assert np.flatnonzero(again.failed).tolist() == sorted(clear.tolist())


def _judged(data: dict, recorded: dict, found: dict) -> compare.Verdict:
    """The rule on ``found`` against ``recorded`` for the rows of a golden set."""
    size_a, size_b = data["size_a"].max(axis=1), data["size_b"].max(axis=1)
    return compare.judge(recorded, found, {k: data[k] for k in ("causes", "tied", "tie_width")},
                         np.maximum(size_a, size_b), 0.5 * (size_a + size_b))


def first_row(data: dict, cause: str, only: bool = True) -> int:
    """The first row borderline for ``cause`` (and for nothing else when ``only``)."""
    causes = data["causes"].astype(np.int64)
    bit = rule.CAUSE_BIT[cause]
    return int(np.flatnonzero((causes == bit) if only else (causes & bit) != 0)[0])


def test_a_borderline_row_passes_only_within_its_cause():
    """A feature row may change its features but not its point; a clip row its manifold; a
    tie row may answer with another axis of its tied set, the depth within the tie's width,
    but not with an axis outside the set."""
    data = store.load("box_extremes")
    recorded = store.unpack_contacts(data)
    found = {name: value.copy() for name, value in recorded.items()}
    feature, clip = first_row(data, "feature"), first_row(data, "clip", only=False)
    found["feature_b"][feature] += 1
    found["manifold_count"][clip] -= 1
    verdict = _judged(data, recorded, found)
    assert verdict.relaxed[[feature, clip]].all() and not verdict.failed.any()
    found["point"][feature] += 1e-6
    assert _judged(data, recorded, found).failed[feature]
    stacking = store.load("box_stacking")
    recorded = store.unpack_contacts(stacking)
    tie = first_row(stacking, "tie")
    tied = [a for a in range(15) if stacking["tied"][tie] >> a & 1]
    other = next(a for a in tied if a != recorded["axis"][tie])
    scale = 0.5 * (stacking["size_a"][tie].max() + stacking["size_b"][tie].max())
    for axis, change, fails in ((other, 0.5, False), (other, 4.0, True),
                                (next(a for a in range(15) if a not in tied), 0.0, True)):
        found = {name: value.copy() for name, value in recorded.items()}
        found["axis"][tie] = axis
        found["depth"][tie] += change * stacking["tie_width"][tie] * scale
        found["normal"][tie] = -found["normal"][tie]
        assert _judged(stacking, recorded, found).failed[tie] == fails, (axis, change)
