"""Predictions and errors of a pair's exported models on labelled rows (validation or test).

The exported tensors are run with the inference side's NumPy MLPs
(:mod:`impactnet.models.learned.mlp`), so the figures are those of the float32 networks that serving
runs. Everything is measured in the canonical frame, where errors equal the world frame's (a sign
flip and a rotation preserve angles and distances).

Per row (:func:`committee_predictions`): the region is the exact labeller's
(:mod:`impactnet.models.learned.region_label`), which equals the data's label by construction (both
are the exact solver's decision), so the rows' labels stand in for it; confidence 1. The normal and
depth are the labeller's too (the targets'). For a contact region with a committee, that region's K
members give the point, averaged, with the normal spread (largest angle between two member normals,
degrees) and the point spread (largest distance between two member points, fraction of the shortest
edge e). Rows of a region without a committee are answered by the exact solver (``exact`` True,
output = target).

Errors (:func:`contact_errors`): normal angle (degrees) and point distance (fraction of e).
A row where prediction and truth disagree on contact vs none has error +inf in both
(:data:`MISMATCH_ERROR`); two "none" have error 0. Summaries of the committee use only the
rows where both say contact and report the two mismatch rates separately.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.learned import canonical as cn
from impactnet.models.learned.kernel_pair import AUTO_EXACT_TYPES
from impactnet.models.learned.mlp import MLP, MLPSpec, MLPStack
from impactnet.models.metrics import angle_deg, summarise
from impactnet.training.data.pair_data import EXACT_POINT_LABEL, UNSURE_LABEL, PairData

#: Error (degrees and fraction of e) of a row predicted "none" that is a contact or vice versa:
#: no tolerance accepts it.
MISMATCH_ERROR = np.inf
#: How a mismatch enters reported summaries (finite, for JSON): the worst normal (180 degrees)
#: and a point error of one shortest edge.
MISMATCH_REPORTED = {"normal_deg": 180.0, "point": 1.0}


def build_mlps(tensors: dict, mlps: dict) -> dict[str, MLP]:
    """The inference side's MLP of every manifest entry in ``mlps``."""
    return {name: MLP.from_tensors(name, tensors, MLPSpec.from_dict(entry))
            for name, entry in mlps.items()}


def _max_pairwise(vectors: np.ndarray, angle: bool) -> np.ndarray:
    """Largest pairwise angle (degrees, unit vectors) or distance over K members (K, m, 3)."""
    best = np.zeros(vectors.shape[1])
    for i in range(len(vectors)):
        for j in range(i + 1, len(vectors)):
            if angle:
                value = angle_deg(vectors[i], vectors[j])
            else:
                value = np.linalg.norm(vectors[i] - vectors[j], axis=1)
            best = np.maximum(best, value)
    return best


def committee_predictions(models: dict[str, MLP], experts: dict[str, list[str]],
                          regions: list[str], features: np.ndarray, labels: np.ndarray,
                          targets: np.ndarray, unclipped: np.ndarray, scale: float,
                          edge: float) -> dict:
    """The committee's answer on rows ``features`` (n, 12); see the module docstring.

    ``labels`` (n,) are the rows' region classes (-1: no committee, -2: edge-edge, whose
    unclipped point is exact), ``targets`` (n, 7) their
    exact contact-v1 outputs, ``unclipped`` (n, 3) the labeller's unclipped points
    (canonical, / L), to which the experts' residuals are added.

    Returns
    -------
    dict of ndarray, n rows each
        ``region`` int (class index), ``confidence``, ``exact`` (bool: answered exactly),
        ``output`` (n, 7) (canonical point / L, unit normal, depth / e),
        ``normal_spread_deg``, ``point_spread`` (fraction of e).
    """
    n = len(features)
    exact = labels == UNSURE_LABEL
    out = {"region": labels.copy(), "confidence": np.ones(n), "exact": exact,
           "output": np.zeros((n, cn.N_CONTACT_OUTPUTS)), "normal_spread_deg": np.zeros(n),
           "point_spread": np.zeros(n)}
    out["output"][exact] = targets[exact]
    contact = labels != 0
    out["output"][contact, 3:] = targets[contact, 3:]
    edges = labels == EXACT_POINT_LABEL
    out["output"][edges, :3] = unclipped[edges]
    for r, key in enumerate(regions):
        rows = np.flatnonzero(labels == r)
        if r == 0 or rows.size == 0:
            continue
        members = MLPStack([models[m] for m in experts[key]]).forward(features[rows])
        members = members.astype(np.float64)
        normals = members[:, :, 3:6] / np.maximum(
            np.linalg.norm(members[:, :, 3:6], axis=2, keepdims=True), cn.NORMAL_NORM_MIN)
        out["output"][rows, :3] = unclipped[rows] + members[:, :, :3].mean(axis=0)
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
    normal_deg = angle_deg(normal, targets[:, 3:6])
    point = np.linalg.norm(output[:, :3] - targets[:, :3], axis=1) * scale / edge
    both = predicted_contact & true_contact
    mismatch = predicted_contact != true_contact
    errors = {"normal_deg": np.where(both, normal_deg, 0.0),
              "point": np.where(both, point, 0.0),
              "depth": np.where(both, np.abs(output[:, 6] - targets[:, 6]), 0.0)}
    for name in errors:
        errors[name][mismatch] = MISMATCH_ERROR
    return errors



def evaluate_rows(data: PairData, split: str, models: dict[str, MLP], blocks: dict,
                  single: str | None) -> dict:
    """Committee (and single) predictions and errors on a split, as per-row arrays."""
    rows = data.rows(split)
    features, targets = data.features[rows], data.targets[rows].astype(np.float64)
    pred = committee_predictions(models, blocks["experts"], blocks["classifier"]["regions"],
                                 features, data.labels[rows], targets,
                                 data.unclipped[rows].astype(np.float64), data.scale, data.edge)
    true_contact = data.keys[rows] != cn.NONE_KEY
    pred_contact = pred["region"] != 0
    pred["true_region"] = data.labels[rows]
    pred["true_contact"] = true_contact
    # impactnet.models.learned.pair_runtime.AUTO_EXACT_TYPES, clipped
    untrusted = np.zeros(len(rows), bool)
    for code in AUTO_EXACT_TYPES:
        untrusted |= np.char.startswith(data.keys[rows].astype(str), CONTACT_TYPES[code] + ":")
    pred["auto_exact"] = pred["exact"] | (untrusted & (pred["true_region"] >= 1))
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
        "no_committee_share": float((pred["true_region"] == UNSURE_LABEL).mean()),  # exact
        "exact_point_share": float((pred["true_region"] == EXACT_POINT_LABEL).mean()),
        "committee": {"normal_deg": summarise(errors["normal_deg"][both]),
                      "point_fraction": summarise(errors["point"][both]),
                      "depth_fraction": summarise(errors["depth"][both])},
    }
    if "single_errors" in pred:
        contact = pred["true_contact"]
        metrics["single"] = {"normal_deg": summarise(pred["single_errors"]["normal_deg"][contact]),
                             "point_fraction": summarise(pred["single_errors"]["point"][contact])}
    return metrics
