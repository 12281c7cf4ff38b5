"""Errors of a method against the exact solver, on the same poses.

* A pose counts when the exact solver says that the boxes touch (``colliding``).
* Missed: the method says "no contact" there. Misses enter the miss rate and the contact-type
  accuracy (as wrong) but not the angle and point statistics, which need an answer.
* Normal error: the angle between the two unit normals, :func:`impactnet.models.metrics.angle_deg`.
* Point error: the distance between the two impact points as a percentage of the smaller
  body's shortest edge.
* Contact-type accuracy: the share of counted poses whose type equals the exact one; None for
  methods without contact types (FCL, polygon meshes).
* Within tolerance: the share of counted poses answered within the scene's accuracy
  (``[accuracy]`` of the scene file: normal angle and point error as a fraction of the
  shortest edge); a miss is outside.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from impactnet.models.metrics import angle_deg, summarise


@dataclass
class RowErrors:
    """Per-pose errors (NaN where not compared)."""

    counted: np.ndarray  # (n,) bool: the exact solver says contact
    missed: np.ndarray  # (n,) bool: counted, but the method says no contact
    normal_deg: np.ndarray  # (n,) angle error, degrees
    point_pct: np.ndarray  # (n,) point error, % of the smaller body's shortest edge
    type_ok: np.ndarray | None  # (n,) bool, or None without types


@dataclass
class ErrorSummary:
    """The error columns of one method on one pose set."""

    poses: int  # poses compared
    contacts: int  # of which the exact solver says contact
    missed: int  # of those, the method says no contact
    miss_rate: float  # missed / contacts
    normal_deg_median: float | None
    normal_deg_p99: float | None
    normal_deg_max: float | None
    point_pct_median: float | None
    point_pct_p99: float | None
    point_pct_max: float | None
    type_accuracy: float | None  # None: the method has no contact types
    within_tolerance: float | None = None  # share within (normal_deg, point_pct) tolerance

    def to_dict(self) -> dict:
        return asdict(self)


def row_errors(answer, reference, scale: np.ndarray) -> RowErrors:
    """Per-pose errors of ``answer`` against ``reference`` (both :class:`methods.Answer`).

    Parameters
    ----------
    answer, reference : impactnet.training.bench.methods.Answer
        The method's and the exact solver's answers for the same n poses.
    scale : ndarray, shape (n,)
        The smaller body's shortest edge per pose, metres.
    """
    counted = np.asarray(reference.colliding, bool)
    missed = counted & ~np.asarray(answer.colliding, bool)
    both = counted & ~missed
    normal = np.full(len(counted), np.nan)
    point = np.full(len(counted), np.nan)
    normal[both] = angle_deg(answer.normal[both], reference.normal[both])
    point[both] = 100.0 * np.linalg.norm(answer.point[both] - reference.point[both],
                                         axis=1) / scale[both]
    type_ok = None
    if answer.contact_type_code is not None:
        type_ok = counted & (np.asarray(answer.contact_type_code)
                             == np.asarray(reference.contact_type_code))
    return RowErrors(counted, missed, normal, point, type_ok)


def _stats(values: np.ndarray) -> tuple[float | None, float | None, float | None]:
    stats = summarise(values)
    return stats["median"], stats["p99"], stats["max"]


def method_summary(errors: RowErrors, rows=None, tolerance=None) -> ErrorSummary:
    """Summary statistics over all poses (or over ``rows``, an index or boolean mask).

    ``tolerance``: (normal degrees, point per cent) for ``within_tolerance``; None: not computed.
    """
    if rows is not None:
        errors = RowErrors(errors.counted[rows], errors.missed[rows], errors.normal_deg[rows],
                           errors.point_pct[rows],
                           None if errors.type_ok is None else errors.type_ok[rows])
    contacts = int(errors.counted.sum())
    missed = int(errors.missed.sum())
    normal = _stats(errors.normal_deg)
    point = _stats(errors.point_pct)
    accuracy = None
    if errors.type_ok is not None and contacts:
        accuracy = float(errors.type_ok[errors.counted].mean())
    within = None
    if tolerance is not None and contacts:
        with np.errstate(invalid="ignore"):  # NaN (not compared) is outside
            ok = (errors.normal_deg <= tolerance[0]) & (errors.point_pct <= tolerance[1])
        within = float(ok[errors.counted].mean())
    return ErrorSummary(len(errors.counted), contacts, missed,
                        missed / contacts if contacts else 0.0, *normal, *point, accuracy,
                        within)


def by_group(errors: RowErrors, groups: np.ndarray) -> dict:
    """Medians and p99 per group value (e.g. per Figure 2 tilt): lists aligned with ``group``."""
    keys = ("normal_deg_median", "normal_deg_p99", "point_pct_median", "point_pct_p99",
            "miss_rate")
    out = {"group": [], **{key: [] for key in keys}}
    for value in np.unique(groups):
        summary = method_summary(errors, groups == value)
        out["group"].append(float(value))
        for key in keys:
            out[key].append(getattr(summary, key))
    return out
