"""Predictions and errors of a pair's exported models on labelled rows (validation or test).

The exported tensors are run with the inference side's NumPy MLPs (:mod:`models.mlp`), so the
figures are those of the float32 networks that serving runs. Everything is measured in the
canonical frame, where errors equal the world frame's (a sign flip and a rotation preserve
angles and distances).

Per row (:func:`committee_predictions`): the classifier's region (argmax) and confidence (its
softmax probability); for a predicted contact region, that region's K members, averaged
(normal renormalised), the normal spread (largest angle between two member normals, degrees),
the point spread (largest distance between two member points, fraction of the shortest edge
e) and the raw predicted depth (fraction of e, not clipped).

Errors (:func:`contact_errors`): normal angle (degrees) and point distance (fraction of e).
A row where prediction and truth disagree on contact vs none has error +inf in both
(:data:`MISMATCH_ERROR`); two "none" have error 0. Summaries of the committee use only the
rows where both say contact and report the two mismatch rates separately.
"""
from __future__ import annotations

import numpy as np

from models import canonical as cn
from models.mlp import MLP, MLPSpec, MLPStack
from training.pair_data import PairData

#: Error (degrees and fraction of e) of a row predicted "none" that is a contact or vice versa:
#: no tolerance accepts it.
MISMATCH_ERROR = np.inf
#: How a mismatch enters reported summaries (finite, for JSON): the worst normal (180 degrees)
#: and a point error of one shortest edge.
MISMATCH_REPORTED = {"normal_deg": 180.0, "point": 1.0}
#: Percentiles reported for every error.
PERCENTILES = (50, 95, 99)


def build_mlps(tensors: dict, mlps: dict) -> dict[str, MLP]:
    """The inference side's MLP of every manifest entry in ``mlps``."""
    return {name: MLP.from_tensors(name, tensors, MLPSpec.from_dict(entry))
            for name, entry in mlps.items()}


def softmax(logits: np.ndarray) -> np.ndarray:
    """Row-wise softmax (n, R) in float64."""
    z = np.asarray(logits, np.float64)
    z = np.exp(z - z.max(axis=1, keepdims=True))
    return z / z.sum(axis=1, keepdims=True)


def _max_pairwise(vectors: np.ndarray, angle: bool) -> np.ndarray:
    """Largest pairwise angle (degrees, unit vectors) or distance over K members (K, m, 3)."""
    best = np.zeros(vectors.shape[1])
    for i in range(len(vectors)):
        for j in range(i + 1, len(vectors)):
            if angle:
                cos = np.clip((vectors[i] * vectors[j]).sum(axis=1), -1.0, 1.0)
                value = np.degrees(np.arccos(cos))
            else:
                value = np.linalg.norm(vectors[i] - vectors[j], axis=1)
            best = np.maximum(best, value)
    return best


def committee_predictions(models: dict[str, MLP], classifier: str,
                          experts: dict[str, list[str]], regions: list[str],
                          features: np.ndarray, scale: float, edge: float) -> dict:
    """The committee's answer on rows ``features`` (n, 12); see the module docstring.

    Returns
    -------
    dict of ndarray, n rows each
        ``region`` int (class index), ``confidence``, ``output`` (n, 7) (canonical point / L,
        unit normal, depth / e), ``normal_spread_deg``, ``point_spread`` (fraction of e).
    """
    n = len(features)
    probs = softmax(models[classifier](features))
    region = probs.argmax(axis=1)
    out = {"region": region, "confidence": probs[np.arange(n), region],
           "output": np.zeros((n, cn.N_CONTACT_OUTPUTS)), "normal_spread_deg": np.zeros(n),
           "point_spread": np.zeros(n)}
    for r, key in enumerate(regions):
        rows = np.flatnonzero(region == r)
        if r == 0 or rows.size == 0:
            continue
        members = MLPStack([models[m] for m in experts[key]]).forward(features[rows])
        members = members.astype(np.float64)
        normals = members[:, :, 3:6] / np.maximum(
            np.linalg.norm(members[:, :, 3:6], axis=2, keepdims=True), cn.NORMAL_NORM_MIN)
        mean = members.mean(axis=0)
        mean[:, 3:6] = cn.unit_normals(mean[:, 3:6])
        out["output"][rows] = mean
        out["normal_spread_deg"][rows] = _max_pairwise(normals, angle=True)
        out["point_spread"][rows] = _max_pairwise(members[:, :, :3], angle=False) * scale / edge
    return out


def contact_errors(output: np.ndarray, predicted_contact: np.ndarray, targets: np.ndarray,
                   true_contact: np.ndarray, scale: float, edge: float) -> dict:
    """Normal (degrees) and point (fraction of e) errors of canonical outputs (n, 7).

    Rows where ``predicted_contact != true_contact`` get :data:`MISMATCH_ERROR`; rows that
    are "none" on both sides get 0.
    """
    normal = cn.unit_normals(output[:, 3:6])
    cos = np.clip((normal * targets[:, 3:6]).sum(axis=1), -1.0, 1.0)
    normal_deg = np.degrees(np.arccos(cos))
    point = np.linalg.norm(output[:, :3] - targets[:, :3], axis=1) * scale / edge
    both = predicted_contact & true_contact
    mismatch = predicted_contact != true_contact
    errors = {"normal_deg": np.where(both, normal_deg, 0.0),
              "point": np.where(both, point, 0.0),
              "depth": np.where(both, np.abs(output[:, 6] - targets[:, 6]), 0.0)}
    for name in errors:
        errors[name][mismatch] = MISMATCH_ERROR
    return errors


def summarise(values: np.ndarray) -> dict:
    """Median, mean, p95, p99 and max of finite errors (empty: None)."""
    values = np.asarray(values, np.float64)
    if values.size == 0:
        return {"median": None, "mean": None, "p95": None, "p99": None, "max": None}
    stats = dict(zip(("median", "p95", "p99"), np.percentile(values, PERCENTILES).tolist()))
    return {**stats, "mean": float(values.mean()), "max": float(values.max())}


def evaluate_rows(data: PairData, split: str, models: dict[str, MLP], blocks: dict,
                  single: str | None) -> dict:
    """Committee (and single) predictions and errors on a split, as per-row arrays."""
    rows = data.rows(split)
    features, targets = data.features[rows], data.targets[rows].astype(np.float64)
    regions = blocks["classifier"]["regions"]
    pred = committee_predictions(models, blocks["classifier"]["mlp"], blocks["experts"],
                                 regions, features, data.scale, data.edge)
    true_contact = data.keys[rows] != cn.NONE_KEY
    pred_contact = pred["region"] != 0
    pred["true_region"] = data.labels[rows]
    pred["true_contact"] = true_contact
    pred["errors"] = contact_errors(pred["output"], pred_contact, targets, true_contact,
                                    data.scale, data.edge)
    if single is not None:
        out = models[single](features).astype(np.float64)
        pred["single_errors"] = contact_errors(out, true_contact, targets, true_contact,
                                               data.scale, data.edge)
    return pred


def committee_metrics(pred: dict) -> dict:
    """Region accuracy, mismatch rates and committee / single error summaries of a split."""
    both = (pred["region"] != 0) & pred["true_contact"]
    errors = pred["errors"]
    metrics = {
        "rows": int(len(both)),
        "region_accuracy": float((pred["region"] == pred["true_region"]).mean()),
        "missed_contact_share": float(((pred["region"] == 0) & pred["true_contact"]).mean()),
        "false_contact_share": float(((pred["region"] != 0) & ~pred["true_contact"]).mean()),
        "unsure_region_share": float((pred["true_region"] < 0).mean()),
        "committee": {"normal_deg": summarise(errors["normal_deg"][both]),
                      "point_fraction": summarise(errors["point"][both]),
                      "depth_fraction": summarise(errors["depth"][both])},
    }
    if "single_errors" in pred:
        contact = pred["true_contact"]
        metrics["single"] = {"normal_deg": summarise(pred["single_errors"]["normal_deg"][contact]),
                             "point_fraction": summarise(pred["single_errors"]["point"][contact])}
    return metrics
