"""The comparison rule of the golden answers, applied to contact rows (not a test module).

A row is *clear* when none of its recorded margins is below its tolerance
(:mod:`tests.golden.rule`); a clear row must match: equal ``colliding``, ``axis``, contact type
and features; points, depths and manifold points within ``MATCH_TOL_REL`` x the pair's scale
(coordinates also within ``COORDINATE_ULPS`` of their own magnitude), normals within
``NORMAL_TOL_RAD``, the pressure integral within ``MATCH_TOL_REL`` x scale^3. Manifolds compare
as sets of (point, depth): the solver orders equally deep points by candidate order, which a
re-run that rounds differently may not reproduce, and the set is the answer.

A borderline row is compared with its causes' relaxations:

* contact: anything may differ (the pair is at contact / no contact);
* tie: anything but ``colliding`` may differ, provided the new axis is in the recorded tied
  set (the axes a borderline decision could hand the answer to; any feature of that set is
  accepted) and the depth moves by at most the recorded ``tie_width``;
* feature: the contact type, the features and the manifold may differ;
* clip: the manifold may differ;
* region: the depth may differ by up to 2 x ``REGION_DEPTH_TOL_REL`` x the solver's scale;
* filter (compound part contacts): anything may differ.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.golden import rule

#: Compared fields, in the order of the mismatch table's columns.
FIELDS = ("colliding", "axis", "type", "features", "normal", "depth", "point", "pressure",
          "manifold")
_COLUMN = {name: k for k, name in enumerate(FIELDS)}
#: Fields a cause may change outright (the tie's and the region's conditions come on top).
ALLOWED = {"contact": FIELDS, "filter": FIELDS, "feature": ("type", "features", "manifold"),
           "clip": ("manifold",)}


def coordinate_tol(values: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Per-coordinate tolerance (metres) of points ``values`` (n, ..., 3) of pairs of scale
    ``scale`` (n,): MATCH_TOL_REL x scale, or COORDINATE_ULPS of the coordinate's spacing."""
    scale = scale.reshape((-1,) + (1,) * (values.ndim - 1))
    return np.maximum(rule.MATCH_TOL_REL * scale,
                      rule.COORDINATE_ULPS * np.spacing(np.abs(values)))


def normal_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (radians) between unit rows of ``a`` and ``b`` (n, 3), from the chord."""
    chord = np.linalg.norm(a - b, axis=1)
    return 2.0 * np.arcsin(np.minimum(0.5 * chord, 1.0))


def manifold_mismatch(recorded: dict, found: dict, scale: np.ndarray) -> np.ndarray:
    """(n,) bool: the manifolds differ as sets of (point, depth) (module docstring)."""
    count_r = recorded["manifold_count"].astype(int)
    count_f = found["manifold_count"].astype(int)
    slots = np.arange(recorded["manifold_points"].shape[1])
    valid_r, valid_f = slots < count_r[:, None], slots < count_f[:, None]
    p_r, p_f = recorded["manifold_points"], found["manifold_points"]
    tol = coordinate_tol(p_r, scale)[:, :, None, :]
    close = (np.abs(p_r[:, :, None] - p_f[:, None]) <= tol).all(axis=3)
    depth_tol = (rule.MATCH_TOL_REL * scale)[:, None, None]
    close &= np.abs(recorded["manifold_depths"][:, :, None]
                    - found["manifold_depths"][:, None]) <= depth_tol
    close &= valid_r[:, :, None] & valid_f[:, None, :]
    covered_r = (close.any(axis=2) | ~valid_r).all(axis=1)
    covered_f = (close.any(axis=1) | ~valid_f).all(axis=1)
    return (count_r != count_f) | ~covered_r | ~covered_f


def mismatches(recorded: dict, found: dict, scale: np.ndarray) -> np.ndarray:
    """(n, len(FIELDS)) bool: which fields of each row differ beyond the clear-row tolerances;
    ``scale`` (n,) is the pair's scale (metres) for points, depths and pressures."""
    point_tol = coordinate_tol(recorded["point"], scale)
    columns = {
        "colliding": recorded["colliding"] != found["colliding"],
        "axis": recorded["axis"] != found["axis"],
        "type": recorded["contact_type_code"] != found["contact_type_code"],
        "features": ((recorded["feature_a"] != found["feature_a"])
                     | (recorded["feature_b"] != found["feature_b"])),
        "normal": ~(normal_angle(recorded["normal"], found["normal"]) <= rule.NORMAL_TOL_RAD),
        "depth": ~(np.abs(recorded["depth"] - found["depth"]) <= rule.MATCH_TOL_REL * scale),
        "point": ~(np.abs(recorded["point"] - found["point"]) <= point_tol).all(axis=1),
        "pressure": ~(np.abs(recorded["pressure"] - found["pressure"])
                      <= rule.MATCH_TOL_REL * scale ** 3),
        "manifold": manifold_mismatch(recorded, found, scale),
    }
    return np.stack([columns[name] for name in FIELDS], axis=1)


@dataclass
class Verdict:
    """The rule's verdict on n rows."""

    bad: np.ndarray  # (n, len(FIELDS)) bool: fields that differ beyond the clear tolerances
    failed: np.ndarray  # (n,) bool: a difference no recorded cause explains
    relaxed: np.ndarray  # (n,) bool: differed, and a borderline cause explains it
    causes: np.ndarray  # (n,) int: the recorded causes


def judge(recorded: dict, found: dict, rule_data: dict, scale: np.ndarray,
          solver_scale: np.ndarray) -> Verdict:
    """Apply the rule (module docstring) to n rows.

    Parameters
    ----------
    recorded, found : dict of ndarray
        The recorded and the re-computed fields (:func:`tests.golden.store.unpack_contacts`).
    rule_data : dict of ndarray
        ``causes``, ``tied`` and ``tie_width`` (x ``solver_scale``) of each row.
    scale : ndarray, shape (n,)
        The pair's scale for the tolerances (metres): largest edge of the two bodies.
    solver_scale : ndarray, shape (n,)
        The solver's pair scale (metres), the unit of the recorded widths.
    """
    bad = mismatches(recorded, found, scale)
    causes = rule_data["causes"].astype(np.int64)
    allowed = np.zeros_like(bad)
    for cause, fields in ALLOWED.items():
        rows = (causes & rule.CAUSE_BIT[cause]) != 0
        for name in fields:
            allowed[rows, _COLUMN[name]] = True
    change = np.abs(recorded["depth"] - found["depth"])
    region_ok = (change <= 2.0 * rule.REGION_DEPTH_TOL_REL * solver_scale
                 + rule.MATCH_TOL_REL * scale)
    allowed[:, _COLUMN["depth"]] |= ((causes & rule.CAUSE_BIT["region"]) != 0) & region_ok
    axis = found["axis"].astype(np.int64)
    in_set = np.where(axis >= 0, (rule_data["tied"].astype(np.int64) >> np.maximum(axis, 0)) & 1,
                      recorded["axis"] < 0).astype(bool)
    tie_ok = (((causes & rule.CAUSE_BIT["tie"]) != 0) & in_set & ~bad[:, _COLUMN["colliding"]]
              & (change <= rule_data["tie_width"] * solver_scale + rule.MATCH_TOL_REL * scale))
    failed = (bad & ~allowed).any(axis=1) & ~tie_ok
    return Verdict(bad, failed, bad.any(axis=1) & ~failed, causes)


def describe(verdict: Verdict, rows: np.ndarray, labels=None, sensitivity=None,
             limit: int = 10) -> str:
    """A few failing rows as text: index, label, causes, the differing fields and, where the
    recorded rounding sensitivity (:mod:`tests.golden.sensitivity`) exceeds the match
    tolerance, that the row is ill-conditioned."""
    lines = []
    for r in rows[:limit]:
        fields = [FIELDS[k] for k in np.flatnonzero(verdict.bad[r])]
        names = [c for c in rule.CAUSES if verdict.causes[r] & rule.CAUSE_BIT[c]] or ["clear"]
        label = f" ({labels[r]})" if labels is not None else ""
        lines.append(f"row {r}{label}: {', '.join(fields)} differ; causes {'+'.join(names)}"
                     + ill_conditioned(sensitivity, r))
    more = f"\n... and {len(rows) - limit} more" if len(rows) > limit else ""
    return "\n".join(lines) + more


def ill_conditioned(sensitivity, r) -> str:
    """A note for row ``r`` whose recorded sensitivity exceeds MATCH_TOL_REL, else ''."""
    if sensitivity is None or not sensitivity[r] > rule.MATCH_TOL_REL:
        return ""
    return (f"; ill-conditioned: {PROBE_NOTE} moved it by {float(sensitivity[r]):.1e} x scale "
            "at recording")


#: How the recorder measured the sensitivity (tests.golden.sensitivity).
PROBE_NOTE = "a 4-ulp change of the inputs"
