"""Per-row errors of a predictor against the exact labels, and their summaries.

Rules (docs/evaluation.md):

* Reference: the exact solver's labels of the test rows (``colliding``, ``point``,
  ``normal``, ``depth``, ``contact_type_code``, ``feature_a``, ``feature_b``).
* Contact / no contact: a row the exact solver calls colliding and the predictor separated is
  *missed*; the other way round a *false contact*. Both are type errors (the contact type
  "none" differs) and region errors; they are counted, and they have no point or normal error.
* Point, normal and depth errors are measured on the rows both call colliding: normal as the angle
  between the unit normals (degrees, :func:`impactnet.training.bench.accuracy.errors.angle_deg`),
  point as the distance in % of the pair's shortest edge e, depth as ``|d - d_exact|`` in % of e and
  in millimetres.
* Region = (contact type, feature of A, feature of B) in world ids, as the exact solver labels
  it; a row is right when all three agree ("none" agrees with "none"). Contact-type accuracy
  compares the type alone. ``single`` predicts no type: both are None for it.
* A region mismatch whose answer is still within the scene's accuracy (normal and point) is
  *benign*: the same contact under another name (e.g. a symmetric relabelling of a face-face
  contact); it is counted apart, never hidden.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.learned.canonical import region_key
from impactnet.models.metrics import summarise
from impactnet.training.bench.accuracy.errors import row_errors

#: Boundary-distance bin edges (fractions of e): one bin per decade, plus a bin below the first
#: edge (down to 0) and one from the last edge up.
BOUNDARY_EDGES = tuple(10.0 ** k for k in range(-6, 1))
#: Region confusions listed per pair and pooled (most frequent first).
TOP_CONFUSIONS = 10
#: Error summaries (keys of :func:`impactnet.models.metrics.summarise`).
STATS = ("median", "mean", "p95", "p99", "max")
N_TYPES = len(CONTACT_TYPES)
#: Packing of a region (type code, feature_a, feature_b) into one int: features -1..25 take
#: 27 values each.
_FEATURE_BASE = 27
_TYPE_STRIDE = _FEATURE_BASE * _FEATURE_BASE


def pack_regions(code, feature_a, feature_b) -> np.ndarray:
    """Regions (n,) int16 ``code * 729 + (feature_a + 1) * 27 + feature_b + 1``."""
    code, fa, fb = (np.asarray(v, np.int16) for v in (code, feature_a, feature_b))
    return code * _TYPE_STRIDE + (fa + 1) * _FEATURE_BASE + (fb + 1)


def region_name(packed: int) -> str:
    """The region key (``impactnet.models.learned.canonical.region_key`` format) of a packed
    region."""
    packed = int(packed)
    return region_key(packed // _TYPE_STRIDE, packed // _FEATURE_BASE % _FEATURE_BASE - 1,
                      packed % _FEATURE_BASE - 1)


@dataclass
class RowRecord:
    """Per-row errors of one predictor on one pair's test rows (n rows each)."""

    colliding: np.ndarray  # (n,) bool, the exact solver says contact
    predicted: np.ndarray  # (n,) bool, the predictor says contact
    normal_deg: np.ndarray  # (n,) float32 normal angle error, degrees; NaN unless both collide
    point_pct: np.ndarray  # (n,) float32 point error, % of e; NaN unless both collide
    depth_pct: np.ndarray  # (n,) float32 |depth error|, % of e; NaN unless both collide
    depth_mm: np.ndarray  # (n,) float32 |depth error|, millimetres; NaN unless both collide
    region_true: np.ndarray  # (n,) int16 exact region, packed (:func:`pack_regions`)
    region_pred: np.ndarray | None  # (n,) int16 predicted region; None: no types predicted
    fallback: np.ndarray  # (n,) bool, a learned predictor's row answered by the exact solver

    @property
    def type_true(self) -> np.ndarray:
        """(n,) exact contact type codes."""
        return self.region_true // _TYPE_STRIDE

    @property
    def type_pred(self) -> np.ndarray | None:
        """(n,) predicted contact type codes (None: no types)."""
        return None if self.region_pred is None else self.region_pred // _TYPE_STRIDE

    @property
    def region_ok(self) -> np.ndarray | None:
        """(n,) bool: the predicted region equals the exact one (None: no types)."""
        return None if self.region_pred is None else self.region_pred == self.region_true

    @property
    def both(self) -> np.ndarray:
        """(n,) bool: both the exact solver and the predictor say contact."""
        return self.colliding & self.predicted

    @staticmethod
    def concat(records: list[RowRecord]) -> RowRecord:
        """The rows of several records, in order (pooling pairs)."""
        fields = RowRecord.__dataclass_fields__
        return RowRecord(**{k: None if getattr(records[0], k) is None else
                            np.concatenate([getattr(r, k) for r in records]) for k in fields})


class _Reference:
    """The exact labels of test rows with the attributes ``row_errors`` reads."""

    def __init__(self, data: dict):
        self.colliding, self.normal, self.point = data["colliding"], data["normal"], data["point"]
        self.contact_type_code = data["contact_type_code"]


def has_types(contacts) -> bool:
    """Whether a predictor names contact types (``single`` answers code 0 while colliding)."""
    return not bool((contacts.colliding & (contacts.contact_type_code == 0)).any())


def row_record(contacts, data: dict, name: str) -> RowRecord:
    """Errors of ``contacts`` (a predictor's `Contacts` on the test rows ``data``).

    Parameters
    ----------
    contacts : impactnet.models.contacts.Contacts
        The predictor's answers, n rows.
    data : dict
        Test rows (:func:`impactnet.training.evaluate.data.test_rows`): exact labels and ``edge``
        (m).
    name : str
        The predictor's name; for a learned one, rows whose ``predictor`` field says
        ``"exact"`` are fallbacks (``auto``'s own rows say ``"committee"``).
    """
    n, edge = len(contacts), data["edge"]
    errors = row_errors(contacts, _Reference(data), np.full(n, edge))
    predicted = np.asarray(contacts.colliding, bool)
    both = errors.counted & predicted
    depth = np.full(n, np.nan)
    depth[both] = np.abs(contacts.depth[both] - data["depth"][both])
    region_pred = None
    if has_types(contacts):
        region_pred = pack_regions(contacts.contact_type_code, contacts.feature_a,
                                   contacts.feature_b)
    f32 = np.float32
    return RowRecord(errors.counted, predicted, errors.normal_deg.astype(f32),
                     errors.point_pct.astype(f32), (100.0 * depth / edge).astype(f32),
                     (1000.0 * depth).astype(f32),
                     pack_regions(data["contact_type_code"], data["feature_a"],
                                  data["feature_b"]),
                     region_pred, (np.asarray(contacts.predictor) == "exact") & (name != "exact"))


def summaries(record: RowRecord) -> dict:
    """Counts, accuracies, fallback share and error summaries of one record."""
    both, n = record.both, len(record.colliding)
    out = {"rows": n, "contacts": int(record.colliding.sum()),
           "both_colliding": int(both.sum()),
           "missed_contacts": int((record.colliding & ~record.predicted).sum()),
           "false_contacts": int((~record.colliding & record.predicted).sum()),
           "type_accuracy": None, "region_accuracy": None,
           "fallback_share": float(record.fallback.mean()) if n else None}
    if record.region_pred is not None and n:
        out["type_accuracy"] = float((record.type_pred == record.type_true).mean())
        out["region_accuracy"] = float(record.region_ok.mean())
    for key in ("normal_deg", "point_pct", "depth_pct", "depth_mm"):
        out[key] = summarise(getattr(record, key)[both])
    if record.region_pred is not None:
        out["experts"] = expert_rows(record)
    return out


def expert_rows(record: RowRecord) -> dict:
    """Point error (% of e) where a learned predictor's experts answer: rows in contact on both
    sides, not sent to the exact solver and whose point is not the exact one (edge-edge and
    aligned face rows take the exact point, issue 18). Share of such rows, median, p90, p99."""
    both = record.both
    learned = both & ~record.fallback & (record.point_pct != 0.0)
    values = np.asarray(record.point_pct[learned], np.float64)
    share = float(learned.sum() / both.sum()) if both.any() else None
    if values.size == 0:
        return {"share": share, "median": None, "p90": None, "p99": None}
    median, p90, p99 = np.percentile(values, [50.0, 90.0, 99.0]).tolist()
    return {"share": share, "median": median, "p90": p90, "p99": p99}


def type_confusion(record: RowRecord) -> list[list[int]] | None:
    """Counts (7, 7) of exact type (rows) against predicted type (columns), CONTACT_TYPES order;
    None for a predictor without types."""
    if record.region_pred is None:
        return None
    cells = record.type_true.astype(np.int64) * N_TYPES + record.type_pred
    return np.bincount(cells, minlength=N_TYPES * N_TYPES).reshape(N_TYPES, N_TYPES).tolist()


def top_confusions(record: RowRecord, group: np.ndarray | None = None,
                   names: list[str] | None = None, limit: int = TOP_CONFUSIONS) -> list[dict]:
    """The most frequent (exact region -> predicted region) mistakes, with their row counts.

    ``group`` (n,) int (e.g. the pair index of pooled rows) and its ``names`` keep the regions
    of different pairs apart (their feature ids name features of other boxes).
    """
    if record.region_pred is None:
        return []
    wrong = ~record.region_ok
    group = np.zeros(len(wrong), np.int64) if group is None else np.asarray(group, np.int64)
    span = N_TYPES * _TYPE_STRIDE
    cells = (group[wrong] * span + record.region_true[wrong]) * span + record.region_pred[wrong]
    values, counts = np.unique(cells, return_counts=True)
    order = np.argsort(-counts, kind="stable")[:limit]
    out = []
    for i in order:
        g, true, pred = values[i] // span // span, values[i] // span % span, values[i] % span
        row = {"exact": region_name(true), "predicted": region_name(pred),
               "rows": int(counts[i]), "share": float(counts[i] / len(wrong))}
        out.append({"pair": names[g], **row} if names is not None else row)
    return out


def mismatch_breakdown(record: RowRecord, distance: np.ndarray, tolerance: tuple[float, float],
                       near: float) -> dict | None:
    """How region mismatches split: type errors, same type with other features, benign (answer
    within ``tolerance`` = (normal degrees, point %)), near a boundary (``distance < near``)."""
    if record.region_pred is None:
        return None
    wrong = ~record.region_ok
    same_type = wrong & (record.type_pred == record.type_true)
    with np.errstate(invalid="ignore"):  # NaN (not both colliding) is never benign
        benign = wrong & record.both & (record.normal_deg <= tolerance[0]) \
            & (record.point_pct <= tolerance[1])
        close = wrong & (distance < near)
    return {"region_mismatches": int(wrong.sum()),
            "type_mismatches": int((wrong & ~same_type).sum()),
            "same_type_other_features": int(same_type.sum()),
            "benign_within_tolerance": int(benign.sum()),
            "near_boundary": int(close.sum())}


def boundary_bins(distance: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Bin index (n,) of each distance (-1 for NaN: separated rows) and the bins' labels."""
    edges = np.asarray(BOUNDARY_EDGES)
    index = np.searchsorted(edges, distance, side="right")
    index = np.where(np.isnan(distance), -1, index)
    labels = [f"< {edges[0]:.0e}"] + [f"{lo:.0e} - {hi:.0e}" for lo, hi in
                                       zip(edges[:-1], edges[1:])] + [f">= {edges[-1]:.0e}"]
    return index, labels


def by_boundary(records: dict[str, RowRecord], distance: np.ndarray) -> dict:
    """Share of contact rows, and per predictor the median / p99 errors and the region error
    rate, per boundary-distance bin (lists aligned with ``labels``)."""
    index, labels = boundary_bins(distance)
    contact = index >= 0
    out = {"labels": labels, "edges": list(BOUNDARY_EDGES),
           "share": [float((index == b).sum() / max(contact.sum(), 1))
                     for b in range(len(labels))], "predictors": {}}
    for name, record in records.items():
        both = record.both
        figures = {f"{k}_{s}": [] for k in ("normal_deg", "point_pct") for s in ("median", "p99")}
        figures["region_error_rate"] = []
        for b in range(len(labels)):
            rows = both & (index == b)
            for key in ("normal_deg", "point_pct"):
                stats = summarise(getattr(record, key)[rows])
                figures[f"{key}_median"].append(stats["median"])
                figures[f"{key}_p99"].append(stats["p99"])
            in_bin = index == b
            figures["region_error_rate"].append(
                None if record.region_ok is None or not in_bin.any()
                else float((~record.region_ok[in_bin]).mean()))
        out["predictors"][name] = figures
    return out


def error_quantiles(record: RowRecord, key: str, points: int = 200) -> dict:
    """The empirical CDF of one error on the both-colliding rows, as ``points`` quantiles."""
    values = getattr(record, key)[record.both].astype(np.float64)
    if values.size == 0:
        return {"p": [], "value": []}
    p = np.linspace(0.0, 1.0, points)
    return {"p": p.tolist(), "value": np.quantile(values, p).tolist()}
