"""The exact solver's intermediate answers for other callers: the learned predictors' canonical
frame and region labeller, and the tests that look inside the separating-axis test.

Every function here checks its inputs as :func:`impactnet.models.box.exact.box_box` does (same
errors) and runs the solver's own row functions (:mod:`impactnet.models.box.kernel_views`), so
its answers are the solver's to the last bit:

* :func:`relative_pose`: stage 1, B in A's frame;
* :func:`decisions` / :func:`decide_one`: stage 2 and the contact's type and features, without
  the clip and the centre of pressure, and the incident face as seen from the reference face
  (the committee's region labeller, :mod:`impactnet.models.learned.region_label`);
  :func:`reference_to_world` maps points given on a reference face to the world;
* :func:`single_pair`, :func:`box_box_one`, :func:`answer_one`: one validated pair as Python
  floats for the learned predictors' one-pair path, and the exact answer for it;
* :func:`axis_table`: the 15 overlaps and unit axes of the separating-axis test;
* :func:`box_box_matrices`: the solver on orientations given as matrices.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models.box import kernel_views as kv
from impactnet.models.box import kernels
from impactnet.models.box.exact import box_box, checked_rows, empty_contacts, fault_error
from impactnet.models.box.kernel_inputs import first_fault
from impactnet.models.contacts import Contacts


def _checked(*inputs) -> tuple[tuple, int]:
    """The six inputs shaped and checked (the solver's errors), and the number of pairs."""
    rows, n = checked_rows(*inputs)
    fault = first_fault(*rows, n)
    if fault:
        raise fault_error(fault, rows, n)
    return tuple(rows), n


def relative_pose(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """B's pose in A's frame as the solver computes it (arguments and errors of ``box_box``).

    Returns
    -------
    half_a, half_b : ndarray, shape (n, 3)
        Half-extents (metres).
    rotation : ndarray, shape (n, 3, 3)
        ``R = R_A^T R_B``.
    translation : ndarray, shape (n, 3)
        ``t = R_A^T (p_B - p_A)`` (metres).
    """
    rows, n = _checked(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    out = (np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3, 3)), np.empty((n, 3)))
    kv.relative_rows(rows, *out)
    return out


class Decisions(NamedTuple):
    """The solver's decision for n pairs
    (:func:`impactnet.models.box.kernel_views.decision_rows` documents every field)."""

    colliding: np.ndarray  # (n,) bool
    axis: np.ndarray  # (n,) int8, 0-14
    depth: np.ndarray  # (n,) metres, the overlap along the axis
    normal: np.ndarray  # (n, 3) world, unit, A towards B
    code: np.ndarray  # (n,) int8, contact type code
    feature_a: np.ndarray  # (n,) int8
    feature_b: np.ndarray  # (n,) int8
    point: np.ndarray  # (n, 3) world, metres: an edge-edge point, else A's centre
    quad: np.ndarray  # (n, 4, 3) metres: a face contact's incident face, (axis, u, w)
    reference: np.ndarray  # (n, 4): reference half-extents (axis, u, w; metres), side (+-1)
    scale: np.ndarray  # (n,) metres, the pair scale


def _decisions(rows: tuple, n: int) -> Decisions:
    out = Decisions(np.empty(n, np.bool_), np.empty(n, np.int8), np.empty(n), np.empty((n, 3)),
                    np.empty(n, np.int8), np.empty(n, np.int8), np.empty(n, np.int8),
                    np.empty((n, 3)), np.empty((n, 4, 3)), np.empty((n, 4)), np.empty(n))
    kv.decision_rows(rows, *out)
    return out


def decisions(size_a, position_a, quaternion_a, size_b, position_b,
              quaternion_b) -> Decisions:
    """The solver's decision for n pairs (arguments and errors of ``box_box``)."""
    return _decisions(*_checked(size_a, position_a, quaternion_a, size_b, position_b,
                                quaternion_b))


def reference_to_world(inputs, pairs, axis, points) -> np.ndarray:
    """Points (m, 3) given in the reference coordinates (along the axis, u, w; metres) of the
    face contacts of pairs ``pairs`` (m,) with face axes ``axis`` (m,) (0-5), in the world frame
    (m, 3), mapped as the solver maps its impact point; ``inputs``: the six inputs of the n
    pairs (as ``box_box``'s)."""
    rows, n = _checked(*inputs)
    pairs, axis = np.require(pairs, np.int64, "CW"), np.require(axis, np.int64, "CW")
    points = np.require(points, np.float64, "CW")
    if not (pairs.ndim == 1 and axis.shape == pairs.shape and points.shape == (len(pairs), 3)
            and ((pairs >= 0) & (pairs < n) & (axis >= 0) & (axis < 6)).all()):
        raise ValueError("reference_to_world: pairs (m,) in [0, n), face axes (m,) in 0-5 and "
                         "points (m, 3) expected")
    out = np.empty((len(pairs), 3))
    kv.reference_rows(rows, pairs, axis, points, out)
    return out


def axis_table(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """The separating-axis test of n pairs: overlaps (n, 15) (metres, +inf for a skipped cross
    axis), unit axes (n, 15, 3) in A's frame (not oriented) and the pair scales (n,) (metres)."""
    rows, n = _checked(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    out = (np.empty((n, 15)), np.empty((n, 15, 3)), np.empty(n))
    kv.axis_rows(rows, *out)
    return out


_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def box_box_matrices(size_a, position_a, rotation_a, size_b, position_b,
                     rotation_b) -> Contacts:
    """``box_box`` with the orientations given as rotation matrices (3, 3) or (n, 3, 3)
    (``v_world = R v_body``), used as given: not checked, and a reflection solves the mirrored
    pair (a canonical frame's improper ``R``). Sizes and positions are checked as by
    ``box_box``."""
    rows, n = _checked(size_a, position_a, _IDENTITY, size_b, position_b, _IDENTITY)
    matrices = [np.require(np.asarray(r, np.float64).reshape(-1, 3, 3), requirements="CW")
                for r in (rotation_a, rotation_b)]
    if any(len(m) not in (1, n) for m in matrices):
        raise ValueError(f"rotations: expected (3, 3) or ({n}, 3, 3)")
    out = empty_contacts(n)
    kv.matrix_rows(rows, *matrices, tuple(getattr(out, name) for name, _, _ in
                                          kernels.OUTPUTS))
    return out


class PairValues(list):
    """One validated pair as six lists of Python floats (quaternions normalised as the solver
    normalises them), in ``box_box`` order; ``rows`` holds the inputs as the solver reads them
    (six (1, w) float64 arrays), for the exact answer (:func:`box_box_one`)."""

    rows: tuple


def single_pair(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """The six inputs of one valid pair as :class:`PairValues`, or None: None means "not a
    single valid pair" (a batch, or invalid input, whose error the batch path raises)."""
    try:
        rows, n = checked_rows(size_a, position_a, quaternion_a, size_b, position_b,
                               quaternion_b)
    except (TypeError, ValueError):
        return None
    unit = np.empty((2, 4))
    if n != 1 or kv.unit_pair(*rows, unit):
        return None
    values = PairValues(r[0].tolist() for r in rows)
    values[2], values[5] = unit.tolist()
    values.rows = tuple(rows)
    return values


def box_box_one(values: PairValues) -> Contacts:
    """The exact answer of one pair of :func:`single_pair` (``box_box`` on its inputs, as six
    vectors: the one-pair kernel)."""
    return box_box(*(r[0] for r in values.rows))


class Decision(NamedTuple):
    """The solver's decision for one pair (:class:`Decisions`' fields as Python values), with
    the pair, from which :func:`answer_one` gives the exact answer."""

    values: PairValues
    colliding: bool
    axis: int
    depth: float
    normal: list  # 3 floats, world
    code: int
    feature_a: int
    feature_b: int
    point: list  # 3 floats, world
    quad: list  # 4 lists of 3 floats
    reference: list  # 4 floats
    scale: float


def decide_one(values: PairValues) -> Decision:
    """The :class:`Decision` of one pair of :func:`single_pair`."""
    found = _decisions(values.rows, 1)
    return Decision(values, *(field[0].tolist() for field in found))


def answer_one(decision: Decision) -> Contacts:
    """The exact answer of the pair behind a :class:`Decision` (one row): the one-pair kernel
    solves it whole, which costs less than carrying the decision into it."""
    return box_box_one(decision.values)
