"""Per-row margins of the box solver's decisions, as the golden files store them (not a test
module).

:func:`box_margins` joins the axis decisions (:mod:`tests.golden.box_decide`) and the face
rows' decisions (:mod:`tests.golden.box_faces`) into the columns of
:data:`tests.golden.rule.BOX_MARGINS`, lengths divided by the solver's pair scale, and checks
them against the solver's own answer: on every row that is not borderline for a cause, the
decision of that cause redone here must be the solver's (:func:`disagreements`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models import contacts as ct
from tests.golden import rule
from tests.golden.box_axes import local_pairs
from tests.golden.box_decide import decide
from tests.golden.box_faces import face_margins

#: Type codes of a face contact by incident rank (1 vertex, 2 edge, 3 face), reference on A
#: (first row) or on B (second row).
RANK_CODES = np.array([[0, ct.FACE_VERTEX, ct.FACE_EDGE, ct.FACE_FACE],
                       [0, ct.VERTEX_FACE, ct.EDGE_FACE, ct.FACE_FACE]])


@dataclass
class BoxMargins:
    """Margins and tie data of N pairs (see :mod:`tests.golden.rule`)."""

    margins: np.ndarray  # (n, len(BOX_MARGINS)) float: lengths x pair scale, or dimensionless
    reach: np.ndarray  # (n,) 1 + |p_B - p_A| / scale
    scale: np.ndarray  # (n,) the solver's pair scale (metres)
    tied: np.ndarray  # (n,) int: bitmask of the axes a tie may hand the answer to
    tie_width: np.ndarray  # (n,) x pair scale: largest depth change between tied answers
    causes: np.ndarray  # (n,) int: borderline causes (tests.golden.rule.CAUSE_BIT)
    colliding: np.ndarray  # (n,) bool, the rule redone here
    axis: np.ndarray  # (n,) int
    type_code: np.ndarray  # (n,) int: the face rows' type from the touching count, else -1


def box_margins(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """:class:`BoxMargins` of N pairs given as the solver's six (n, 3|4) float64 inputs."""
    pose = local_pairs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    found = decide(pose)
    n = len(pose.scale)
    columns = {name: np.full(n, np.inf) for name in rule.MARGIN_NAMES}
    columns["contact"] = found.margins["contact"]
    columns["tie"], columns["band"] = found.margins["tie"], found.margins["band"]
    columns["feature_unit"] = found.margins["feature_unit"]
    type_code = np.full(n, -1)
    rows = np.flatnonzero(found.colliding & (found.axis < 6))
    if rows.size:
        sub = type(pose)(*(x[rows] for x in (pose.ha, pose.hb, pose.r, pose.t, pose.scale,
                                            pose.reach)))
        faces = face_margins(sub, found.axis[rows], found.sat_depth[rows])
        for name in ("feature_unit", "feature_depth", "clip", "region", "empty"):
            columns[name][rows] = faces[name]
        type_code[rows] = RANK_CODES[(found.axis[rows] >= 3).astype(int), faces["rank"]]
    edge = found.colliding & (found.axis >= 6)
    type_code[edge] = ct.EDGE_EDGE
    type_code[~found.colliding] = ct.NONE
    units = {name: kind for name, kind, _ in rule.BOX_MARGINS}
    table = np.stack([columns[name] / (pose.scale if units[name] == "length" else 1.0)
                      for name in rule.MARGIN_NAMES], axis=1)
    return BoxMargins(table, pose.reach, pose.scale, found.tied, found.tie_width / pose.scale,
                      rule.causes_of(table, pose.reach), found.colliding, found.axis, type_code)


def disagreements(margins: BoxMargins, colliding, axis, type_code) -> dict[str, np.ndarray]:
    """Rows where the decisions redone here differ from the solver's answer although no margin
    of that decision is borderline: empty arrays when the margins model the solver's rule.

    Returns ``{"contact": rows, "axis": rows, "type": rows}`` (int arrays).
    """
    causes = margins.causes
    bit = rule.CAUSE_BIT
    clear_contact = (causes & bit["contact"]) == 0
    clear_axis = clear_contact & ((causes & bit["tie"]) == 0)
    clear_type = clear_axis & ((causes & bit["feature"]) == 0)
    return {
        "contact": np.flatnonzero(clear_contact & (margins.colliding != colliding)),
        "axis": np.flatnonzero(clear_axis & (margins.axis != axis)),
        "type": np.flatnonzero(clear_type & (margins.type_code != type_code)),
    }
