"""Model only what a scene requires: after training, each pair's learned path is measured
against the exact solver and the bundle records the decision (issue #21, step 4).

The measurement and the rule are :mod:`impactnet.training.bench.learned.decide`'s
(:func:`~impactnet.training.bench.learned.decide.serve_decision`): ``auto`` (fallback rows included)
must be at least 2x faster than the exact solver at N = 1 and at the batch size on the pair's
first-contact poses, with p99 errors within the scene's tolerance there and wherever the
validation gate measures the learned path (the pair's held-out test split, the manifest's
``test.auto``, and the gate's fresh rows through the served predictor), and no missed
contact; otherwise the pair is served exact-only (``decision.serve``, with
``decision.reasons`` naming each missed figure and its limit), and every learned mode answers
it through the exact solver. The figures behind each decision go into the manifest. Decisions
are recorded before the validation gate runs, so that the gate judges what will be served.
"""
from __future__ import annotations

from dataclasses import asdict, replace

import numpy as np

from impactnet.models.learned.bundle_loader import bundle_in_memory
from impactnet.models.scenes import Scene
from impactnet.training.bench.learned import decide as dc
from impactnet.training.bench.methods import exact_method, predictor_method
from impactnet.training.bench.pose_sets import scene_poses
from impactnet.training.fit.validation_gate import GateConfig, served_figures

#: What the decision measures for a full training run (the issue's N = 1e5) and for ``--quick``.
FULL, QUICK = dc.DecideConfig(), replace(dc.QUICK, poses_per_pair=5_000)
#: Fresh rows per pair the learned path is scored on by default: the gate's served check's.
SERVED_ROWS = GateConfig().served_rows
#: The rule, as recorded with every decision.
RULE = (f"learned only if auto is >= {dc.SPEEDUP_REQUIRED:g}x faster than the exact solver at "
        "N = 1 and at the batch size, within the scene's tolerance on the first-contact poses, "
        "the held-out test split and the gate's fresh rows, with no missed contact")


def record_decisions(scene: Scene, manifest: dict, tensors: dict, quick: bool,
                     log=None, fresh_rows: int = SERVED_ROWS) -> dict:
    """``manifest`` with a ``decision`` in each pair entry (module docstring); the bundle's
    predictors are built in memory from ``manifest`` and ``tensors``.

    ``fresh_rows``: rows per pair of the served check's stream that the learned path is
    scored on (:func:`impactnet.training.fit.validation_gate.served_figures`; the gate's
    ``served_rows``, 0: not scored there).
    """
    from impactnet.models import load_predictor

    config = replace(QUICK if quick else FULL, scene=scene.name)
    served = load_predictor("auto", bundle_in_memory(manifest, tensors))
    exact = exact_method()
    auto = predictor_method("auto", served, "learned")
    poses = scene_poses(scene, config.poses_per_pair * len(scene.pairs), config.seed)
    for k, pair in enumerate(scene.pairs):
        rows = np.flatnonzero(poses.pair == k)
        figures = dc.measure_pair(exact, auto, poses.args(rows), poses.scale[rows], config)
        figures["held_out"] = dc.p99_figures(manifest["pairs"][pair.key]["test"]["auto"])
        if fresh_rows > 0:
            figures["fresh"] = dc.p99_figures(served_figures(served, manifest, scene, k,
                                                             fresh_rows))
        serve, reasons = dc.serve_decision(figures, scene.accuracy)
        manifest["pairs"][pair.key]["decision"] = {
            "serve": serve, "rule": RULE, "reasons": reasons, "config": asdict(config),
            "figures": figures}
        if log is not None:
            log(decision_line(pair.key, manifest["pairs"][pair.key]["decision"]))
    return manifest


def decision_line(key: str, decision: dict | None) -> str:
    """What serves pair ``key`` by its recorded ``decision`` and, for an exact-only pair, why."""
    decision = decision or {"serve": "learned (no decision recorded)"}
    reasons = "; ".join(decision.get("reasons") or [])
    return f"{key}: {decision['serve']}" + (f" ({reasons})" if reasons else "")


def decision_lines(manifest: dict) -> list[str]:
    """:func:`decision_line` of every pair of ``manifest``."""
    return [decision_line(key, block.get("decision"))
            for key, block in manifest["pairs"].items()]
