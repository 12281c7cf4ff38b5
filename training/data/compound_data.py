"""Labelled first-contact rows of a pair of compound bodies (issue #20, step 5).

:func:`compound_rows` draws poses of the families that the pair's bodies make sense for
(:mod:`impactnet.training.data.compound_poses`) and labels them with the exact compound oracle.
The labels are ragged, as the oracle's answer: per-pose columns (``position_b``,
``quaternion_b``, ``family``, ``push`` and the body-level summary) and per-part-contact columns
prefixed ``contact_`` with ``contact_offsets`` (n + 1,) delimiting each pose's rows, the layout
of the service's ragged batch (docs/service.md).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.oracle import compound_contacts
from impactnet.models.compound.parts import bounds
from impactnet.models.compound.summary import summarise
from impactnet.training.data.compound_poses import FAMILIES, family_poses

#: Gap (m) between a container and a cell guide's angle at the nominal pose of the sliding
#: family: inside the 25 mm clearance of issue #20, so that the push closes it.
GUIDE_GAP_M = 0.02


def _extent(parts) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of a body's parts' bounds, body frame (m)."""
    lows, highs = zip(*(bounds(p) for p in parts))
    return np.min(lows, axis=0), np.max(highs, axis=0)


def pair_families(parts_a, parts_b) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The families that suit the pair, each with its nominal pose of B and approach
    direction: a cell guide (parts ``leg_x``/``leg_y``) gets guide sliding, a spreader
    (parts ``head_*``) twistlock entry, anything else stacking and near stacking."""
    names_a, names_b = {p.name for p in parts_a}, {p.name for p in parts_b}
    lo_a, hi_a = _extent(parts_a)
    lo_b, hi_b = _extent(parts_b)
    on_top = np.array([0.0, 0.0, hi_a[2] - lo_b[2]])
    down = np.array([0.0, 0.0, -1.0])
    if {"leg_x", "leg_y"} <= names_a:  # B slides along the guide's inside corner
        beside = np.array([-lo_b[0], hi_a[1] - lo_b[1] + GUIDE_GAP_M, 0.0])
        return {"guide_sliding": (beside, np.array([0.0, -1.0, 0.0]))}
    if any(name.startswith("head_") for name in names_b):
        return {"twistlock_entry": (on_top, down)}
    return {"stacking": (on_top, down), "near_stacking": (on_top, down)}


def compound_rows(parts_a, parts_b, n: int, depth_range_m: tuple[float, float],
                  rng: np.random.Generator) -> dict[str, np.ndarray]:
    """About n labelled poses of B against A (fewer where a first contact is not found).

    Returns
    -------
    dict of ndarray
        Per pose (k rows): ``position_b`` (k, 3) m, ``quaternion_b`` (k, 4), ``family``
        (k,) index into :data:`FAMILIES`, ``push`` (k,) m, ``colliding`` (k,), ``normal``
        (k, 3), ``depth`` (k,) m, ``point`` (k, 3) m (the summary); per part contact:
        ``contact_offsets`` (k + 1,), ``contact_part_a``, ``contact_part_b``,
        ``contact_point`` (c, 3), ``contact_normal`` (c, 3), ``contact_depth`` (c,),
        ``contact_type`` (c,), ``contact_feature_a``, ``contact_feature_b``,
        ``contact_pressure`` (c,) m^3. A is at the origin, unrotated.
    """
    families = pair_families(parts_a, parts_b)
    share = np.full(len(families), n // len(families))
    share[: n - share.sum()] += 1
    columns = []
    for (family, (nominal, approach)), m in zip(families.items(), share):
        position, quaternion, push = family_poses(family, parts_a, parts_b, nominal, approach,
                                                  depth_range_m, int(m), rng)
        columns.append((position, quaternion, push,
                        np.full(len(push), FAMILIES.index(family), np.int8)))
    position, quaternion, push, family = (np.concatenate(c) for c in zip(*columns))
    return label(parts_a, parts_b, position, quaternion) | {
        "position_b": position, "quaternion_b": quaternion, "push": push, "family": family}


def label(parts_a, parts_b, position_b, quaternion_b) -> dict[str, np.ndarray]:
    """The oracle's ragged answer and its summary for B's poses against A at the origin."""
    k = len(position_b)
    found = compound_contacts(parts_a, np.zeros((k, 3)), np.tile([1.0, 0, 0, 0], (k, 1)),
                              parts_b, position_b, quaternion_b)
    summary = summarise(found)
    c = found.contacts
    return {"colliding": summary.colliding, "normal": summary.normal, "depth": summary.depth,
            "point": summary.point, "contact_offsets": found.offsets,
            "contact_part_a": found.part_a, "contact_part_b": found.part_b,
            "contact_point": c.point, "contact_normal": c.normal, "contact_depth": c.depth,
            "contact_type": c.contact_type_code, "contact_feature_a": c.feature_a,
            "contact_feature_b": c.feature_b, "contact_pressure": c.pressure}
