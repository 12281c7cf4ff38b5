"""The comparison rule of the golden answers: tolerances, borderline causes and margin columns.

"Answers unchanged" (the numba switch): on every row whose margin to each decision threshold
exceeds its tolerance below, a re-run must give the recorded answer within
:data:`MATCH_TOL_REL` of the pair's scale in points and depths and :data:`NORMAL_TOL_RAD` in
normals, with equal types and features. A row whose margin to some threshold is below the
tolerance is *borderline*: a re-run that rounds differently may legitimately land on the other
side of that threshold, so the row is compared with that cause's relaxation
(:mod:`tests.golden.compare`) and counted by cause.

Margins are recorded per row (:mod:`tests.golden.box_margins` for box pairs,
:mod:`tests.golden.compound_pairs` for a compound body's part pairs, with
:mod:`tests.golden.compound_filter` for the covered-surface filter and the summary): lengths in
units of the solver's own pair scale (the sum of the two largest half-extents, the unit of every
threshold of :mod:`impactnet.models.box.sat`), cosines and unit-vector components as they are.

Not a test module; imports no solver stage (the golden tests must outlive the switch).
"""
from __future__ import annotations

import numpy as np

#: The solver's thresholds the margins are measured against, as recorded (values of
#: models/box/sat.py, manifold.py and pressure.py at the recording; models/box/tolerances.py
#: since the kernels replaced them): written out here so that the
#: golden tests import no solver stage (the stages are what the kernels replace); the recorder
#: checks them against the solver first (:func:`check_solver_constants`).
TIE_TOL_REL = 1e-12  # x pair scale: face axes within it tie (sat.py)
FACE_AXIS_ANGLE_TOL = 1e-2  # radians: rule 1's band (sat.py)
FACE_AXIS_COS_TOL = float(np.cos(FACE_AXIS_ANGLE_TOL))
DEPTH_GAIN_TOL_REL = 1e-9  # x pair scale: rule 2's depth gain (sat.py)
EDGE_INSIDE_TOL_REL = 1e-9  # x pair scale: rule 3's slack (sat.py)
CONTACT_TOL_REL = 1e-12  # x pair scale: still touching (sat.py)
EDGE_SKEW_TOL_REL = 1e-12  # x pair scale: skipped parallel edges (sat.py)
SNAP_TOL_REL = 1e-12  # x pair scale: clip snap (manifold.py)
PRESSURE_FLOOR_REL = 1e-9  # x pair scale: the pressure's depth floor tau (pressure.py)
REGION_DEPTH_TOL_REL = 1e-9  # x pair scale: the face depth's rule (pressure.py)
SOLVER_CONSTANTS = {
    "impactnet.models.box.tolerances": ("TIE_TOL_REL", "FACE_AXIS_ANGLE_TOL", "FACE_AXIS_COS_TOL",
                                        "DEPTH_GAIN_TOL_REL", "EDGE_INSIDE_TOL_REL",
                                        "CONTACT_TOL_REL", "EDGE_SKEW_TOL_REL", "SNAP_TOL_REL",
                                        "PRESSURE_FLOOR_REL", "REGION_DEPTH_TOL_REL"),
}


def check_solver_constants() -> None:
    """Raise ``AssertionError`` where the solver's thresholds differ from the values written
    here (the recorder calls it: margins measured against stale thresholds are wrong)."""
    import importlib

    for module, names in SOLVER_CONSTANTS.items():
        found = importlib.import_module(module)
        for name in names:
            assert getattr(found, name) == globals()[name], (
                f"{module}.{name} = {getattr(found, name)!r}, tests/golden/rule.py has "
                f"{globals()[name]!r}: update the rule, then re-record with a reason")


#: Agreement of points, depths and manifold points on a clear row (x the pair's scale: the
#: largest edge of the two boxes, or of the two compound bodies' envelopes; metres). The
#: requirement's figure.
MATCH_TOL_REL = 1e-12
#: Agreement of normals on a clear row (radians). The requirement's figure.
NORMAL_TOL_RAD = 1e-12
#: A coordinate of magnitude X is known to its float64 spacing only: points far from the origin
#: (1e9 m in the extreme set) are compared to this many ulps of their own magnitude where
#: that exceeds MATCH_TOL_REL x scale (a bit-identical re-run meets either).
COORDINATE_ULPS = 4
#: Ulps of a decision's magnitude under which its margin is borderline. A re-run that sums the
#: same terms in another order (or fuses a multiply-add) moves each compared quantity by a few
#: ulps of the largest magnitude in its formula, up to ~16 on the longest chains (quaternion ->
#: matrix -> relative pose -> overlap); 64 keeps a factor 4 over that. It stays far below the
#: solver's own 1e-12 tolerances (4500 ulps of the scale), so an exact alignment (a margin of
#: exactly 1e-12 x scale, e.g. equal boxes stacked) is not borderline.
DECISION_TOL_ULPS = 64
#: Borderline length margin, x pair scale x reach (metres / metres): reach x scale is the
#: largest length the decision's formula combines (box pairs: ``scale + |p_B - p_A|``; convex
#: parts: the largest coordinate in A's body frame, a casting 6 m from its container's centre).
DECISION_TOL_REL = DECISION_TOL_ULPS * float(np.finfo(float).eps)
#: Borderline margin of cosines and unit-vector components (dimensionless, magnitude 1): rule
#: 1's band, the incident face's choice, an edge's side.
DECISION_TOL_UNIT = DECISION_TOL_REL
#: Borderline margin of the summary's cluster angle (radians, magnitude ~0.2 rad near 10 deg).
DECISION_TOL_ANGLE = DECISION_TOL_REL

#: Borderline causes, as bits of a row's ``causes``. "contact": contact / no contact (the
#: least overlap at -CONTACT_TOL_REL, an empty pressure region); "tie": the tie rule (face band,
#: rules 1-3, equal axes, the normal's orientation, skipped parallel edges, the most separating
#: axis); "feature": the incident feature (its face, its touching vertices, an edge's side);
#: "clip": the manifold's clip (a candidate at a clip plane or snap distance); "region": the
#: face depth's rule (the region's deepest point at REGION_DEPTH_TOL_REL); "filter": a compound
#: part contact at the covered-surface filter's margin; "summary": the compound summary's
#: deepest contact or cluster membership.
CAUSES = ("contact", "tie", "feature", "clip", "region", "filter", "summary")
CAUSE_BIT = {name: 1 << k for k, name in enumerate(CAUSES)}

#: Margin columns of a box row (and of a compound box-part pair) and their kind: "length"
#: (x pair scale, compared with DECISION_TOL_REL x reach) or "unit" (dimensionless, compared
#: with DECISION_TOL_UNIT), with the cause each belongs to.
BOX_MARGINS = (
    ("contact", "length", "contact"),  # |least overlap + CONTACT_TOL_REL scale|
    ("empty", "length", "contact"),  # |region's deepest depth + tau| (tau: the pressure floor)
    ("tie", "length", "tie"),  # face band, rules 2-3, equal axes, orientation, skew, separated
    ("band", "unit", "tie"),  # rule 1: |cos x sine - FACE_AXIS_COS_TOL x sine| of a cross axis
    ("feature_depth", "length", "feature"),  # incident vertices' |depth + snap tolerance|
    ("feature_unit", "unit", "feature"),  # incident face choice gap; an edge's side component
    ("clip", "length", "clip"),  # clip candidates' tests (inside, snap, crossing ends)
    ("region", "length", "region"),  # |region depth - SAT depth + REGION_DEPTH_TOL_REL scale|
)
MARGIN_NAMES = tuple(name for name, _, _ in BOX_MARGINS)


def causes_of(margins: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """The borderline causes (bits of :data:`CAUSE_BIT`) of rows from their margins.

    Parameters
    ----------
    margins : ndarray, shape (n, len(BOX_MARGINS))
        Margin columns in the order of :data:`BOX_MARGINS` (+inf where a decision does not
        apply).
    reach : ndarray, shape (n,)
        ``1 + |p_B - p_A| / scale`` (dimensionless, >= 1).

    Returns
    -------
    ndarray of int, shape (n,)
    """
    causes = np.zeros(len(reach), np.int64)
    for k, (_, kind, cause) in enumerate(BOX_MARGINS):
        tol = DECISION_TOL_REL * reach if kind == "length" else DECISION_TOL_UNIT
        causes |= np.where(margins[:, k] < tol, CAUSE_BIT[cause], 0)
    return causes


def cause_counts(causes: np.ndarray) -> dict[str, int]:
    """Rows per cause (a row with several causes counts under each) and the clear rows."""
    counts = {name: int(((causes & bit) != 0).sum()) for name, bit in CAUSE_BIT.items()}
    counts["clear"] = int((causes == 0).sum())
    return counts
