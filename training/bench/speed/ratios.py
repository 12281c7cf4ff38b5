"""The ratio arithmetic of the speed columns: ours / MuJoCo, both as time per pair (or per pose)
measured in the same run, so that below 1x we are faster; and issue #32's goals, each an upper
bound on that ratio.

* N = 1, box pairs: ``box_box`` on one pair from Python / MuJoCo's one pair from Python, at
  most :data:`GOAL_BOX_ONE` (1.5x);
* batch, box pairs: ``box_box`` per pair in a batch of 100,000 / MuJoCo's ``mj_collision`` per
  pair over 1,000 explicit pairs (its C rate), at most :data:`GOAL_BOX_BATCH` (1x: at least
  MuJoCo's rate), with the machine's cores;
* compound, N = 1: ``compound_answer`` on one pose / MuJoCo's one pose from Python, at most
  :data:`GOAL_COMPOUND_ONE` (2x);
* compound, batch: ``compound_answer`` per pose in a batch / MuJoCo's one pose from Python, at
  most :data:`GOAL_COMPOUND_BATCH` (1x).
"""
from __future__ import annotations

import math

GOAL_BOX_ONE = 1.5
GOAL_BOX_BATCH = 1.0
GOAL_COMPOUND_ONE = 2.0
GOAL_COMPOUND_BATCH = 1.0
DASH = "–"


def ratio(ours: float | None, theirs: float | None) -> float | None:
    """``ours / theirs`` (times, same unit); None where either is missing or not positive."""
    if ours is None or theirs is None or not (ours > 0 and theirs > 0):
        return None
    if not (math.isfinite(ours) and math.isfinite(theirs)):
        return None
    return ours / theirs


def verdict(value: float | None, goal: float) -> str:
    """"met" where ``value`` (a ratio) is at most ``goal``, "NOT met" above, "not measured"
    without a value."""
    if value is None:
        return "not measured"
    return "met" if value <= goal else "NOT met"


def figure(value: float | None) -> str:
    """A time or count with 3 significant digits, whole numbers from 1,000 on (``1,234``); a
    dash for None."""
    if value is None:
        return DASH
    return f"{value:,.0f}" if abs(value) >= 1000 else f"{value:.3g}"


def times(value: float | None) -> str:
    """A ratio as ``1.23x`` (3 significant digits, whole numbers from 1,000 on); a dash for
    None."""
    return DASH if value is None else f"{figure(value)}x"


def goal_cell(value: float | None, goal: float) -> str:
    """A table cell: the ratio and the verdict against the goal, e.g. ``2.1x, NOT met``."""
    return f"{times(value)}, {verdict(value, goal)}" if value is not None else DASH


def goal_line(what: str, ours_us: float | None, theirs_us: float | None, goal: float) -> str:
    """A report line: both times, the ratio and the verdict, e.g. ``N = 1: 6.0 µs / 4.0 µs =
    1.5x (goal <= 1.5x): met``."""
    value = ratio(ours_us, theirs_us)
    if value is None:
        return f"{what}: not measured (goal <= {goal:g}x)"
    return (f"{what}: {figure(ours_us)} µs / {figure(theirs_us)} µs = {times(value)} "
            f"(goal <= {goal:g}x): {verdict(value, goal)}")
