"""Scene-level figures: the test rows of every pair pooled, against the goals of issue 4.

Per-pair figures live in each pair's manifest block; the goals are stated for the scene's
held-out test set as a whole, so :func:`pooled_figures` pools the per-row errors of all pairs
(:func:`pooling_record` keeps what is needed of one pair's test rows) and compares them with
:data:`GOALS`. :func:`reevaluate` rebuilds the records of a written bundle from the same seeded
data (for bundles trained before the records were kept, or to check one), and
:func:`reevaluate_pair` those of one pair (a pair reused from a bundle,
:mod:`impactnet.training.jobs.bundle_reuse`).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.metrics import summarise
from impactnet.models.scenes import Scene
from impactnet.training.data.datagen import pair_seed
from impactnet.training.data.pair_data import make_pair_data
from impactnet.training.fit.calibrate import auto_keep, calibration_scores
from impactnet.training.fit.pair_eval import MISMATCH_REPORTED, evaluate_rows

#: Issue 4's goals on the default scene's test set: (figure path, bound, "<=" or ">=").
GOALS = {
    "region accuracy": (("region_accuracy",), 0.98, ">="),
    "committee normal median (deg)": (("committee", "normal_deg", "median"), 0.2, "<="),
    "committee normal mean (deg)": (("committee", "normal_deg", "mean"), 1.0, "<="),
    "committee point median (fraction of e)": (("committee", "point_fraction", "median"),
                                               0.005, "<="),
    "committee point mean (fraction of e)": (("committee", "point_fraction", "mean"), 0.015,
                                             "<="),
    "auto p99 normal (deg)": (("auto", "normal_deg", "p99"), 1.0, "<="),
    "auto p99 point (fraction of e)": (("auto", "point_fraction", "p99"), 0.02, "<="),
    "auto fallback share": (("auto", "fallback_share"), 0.10, "<="),
}


def pooling_record(pred: dict, keep: np.ndarray) -> dict:
    """What pooling needs of one pair's evaluated rows
    (:func:`impactnet.training.fit.pair_eval.evaluate_rows`
    output and the rows ``auto`` keeps)."""
    both = (pred["region"] != 0) & pred["true_contact"]
    record = {"region_ok": pred["region"] == pred["true_region"], "both": both,
              "true_contact": pred["true_contact"], "keep": keep,
              "normal": pred["errors"]["normal_deg"], "point": pred["errors"]["point"]}
    if "single_errors" in pred:
        record["single_normal"] = pred["single_errors"]["normal_deg"]
        record["single_point"] = pred["single_errors"]["point"]
    return record


def pooled_figures(records: list[dict]) -> dict:
    """Scene figures of pooled row records, with each goal's bound and whether it is met."""
    rows = {k: np.concatenate([r[k] for r in records]) for k in records[0]}
    both, contact, keep = rows["both"], rows["true_contact"], rows["keep"]
    auto_rows = contact | keep
    figures = {
        "rows": int(len(both)),
        "region_accuracy": float(rows["region_ok"].mean()),
        "committee": {"normal_deg": summarise(rows["normal"][both]),
                      "point_fraction": summarise(rows["point"][both])},
        "auto": {"fallback_share": float(1.0 - keep.mean())},
    }
    for name, key, cap in (("normal_deg", "normal", MISMATCH_REPORTED["normal_deg"]),
                           ("point_fraction", "point", MISMATCH_REPORTED["point"])):
        errors = np.minimum(np.where(keep, rows[key], 0.0), cap)
        figures["auto"][name] = summarise(errors[auto_rows])
    if "single_normal" in rows:
        figures["single"] = {"normal_deg": summarise(rows["single_normal"][contact]),
                             "point_fraction": summarise(rows["single_point"][contact])}
    figures["goals"] = {}
    for goal, (path, bound, sense) in GOALS.items():
        value = figures
        for part in path:
            value = value[part]
        met = value is not None and (value >= bound if sense == ">=" else value <= bound)
        figures["goals"][goal] = {"value": value, "bound": bound, "met": bool(met)}
    return figures


def reevaluate_pair(scene: Scene, index: int, mlps: dict, block: dict, config) -> dict:
    """Row record of the test split of ``scene.pairs[index]`` under written models.

    The pair's data is regenerated from its seed (as :func:`impactnet.training.fit.pair.train_pair`
    made it) and its test rows are evaluated again; for models that training wrote, the record
    equals the one training kept, bit for bit.

    Parameters
    ----------
    scene : Scene
    index : int
        The pair's index in ``scene``.
    mlps : dict
        Name -> the inference side's MLP (:attr:`impactnet.models.bundle.format.Bundle.mlps`), at
        least the networks that ``block`` names.
    block : dict
        The pair's manifest block (``single``, ``classifier``, ``experts``, ``auto``).
    config : impactnet.training.fit.pair.PairTrainConfig
        The config the pair was trained with (its seed and data settings).
    """
    pair = scene.pairs[index]
    size_a, size_b = scene.pair_sizes()[index]
    data = make_pair_data(size_a, size_b, pair_seed(config.seed, pair), scene.depth_fraction,
                          config.data, config.datagen)
    pred = evaluate_rows(data, "test", mlps, block, block["single"])
    keep = auto_keep(calibration_scores(pred, data.depth_fraction), block["auto"])
    return pooling_record(pred, keep)


def reevaluate(scene: Scene, bundle_path, config) -> list[dict]:
    """Row records of every pair's test split of a written bundle, from the seeded data.

    ``config`` is the :class:`impactnet.training.fit.pair.PairTrainConfig` the bundle was trained
    with.
    """
    bundle = read_bundle(bundle_path)
    return [reevaluate_pair(scene, index, bundle.mlps, bundle.manifest["pairs"][pair.key],
                            config) for index, pair in enumerate(scene.pairs)]
