"""Model only what a scene requires: after training, each pair's learned path is measured
against the exact solver and the bundle records the decision (issue #21, step 4).

The measurement and the rule are :mod:`impactnet.training.bench.decide`'s: ``auto`` (fallback
rows included) must be at least 2x faster than the exact solver at N = 1 and at the batch size
on the pair's first-contact poses, with p99 errors within the scene's tolerance and no missed
contact; otherwise the pair is served exact-only (``decision.serve``), and every learned mode
answers it through the exact solver. The figures behind each decision go into the manifest.
"""
from __future__ import annotations

from dataclasses import asdict, replace

import numpy as np

from impactnet.models.bundle.format import bundle_in_memory
from impactnet.models.scenes import Scene
from impactnet.training.bench import decide as dc
from impactnet.training.bench.methods import exact_method, predictor_method
from impactnet.training.bench.pose_sets import scene_poses

#: What the decision measures for a full training run (the issue's N = 1e5) and for ``--quick``.
FULL, QUICK = dc.DecideConfig(), replace(dc.QUICK, poses_per_pair=5_000)


def record_decisions(scene: Scene, manifest: dict, tensors: dict, quick: bool,
                     log=None) -> dict:
    """``manifest`` with a ``decision`` in each pair entry (module docstring); the bundle's
    predictors are built in memory from ``manifest`` and ``tensors``."""
    from impactnet.models import load_predictor

    config = replace(QUICK if quick else FULL, scene=scene.name)
    bundle = bundle_in_memory(manifest, tensors)
    exact = exact_method()
    auto = predictor_method("auto", load_predictor("auto", bundle), "learned")
    poses = scene_poses(scene, config.poses_per_pair * len(scene.pairs), config.seed)
    for k, pair in enumerate(scene.pairs):
        rows = np.flatnonzero(poses.pair == k)
        figures = dc.measure_pair(exact, auto, poses.args(rows), poses.scale[rows], config)
        serve = dc.serve_decision(figures, scene.accuracy)
        manifest["pairs"][pair.key]["decision"] = {
            "serve": serve,
            "rule": f"learned only if auto is >= {dc.SPEEDUP_REQUIRED:g}x faster than the "
                    "exact solver at N = 1 and at the batch size, within the scene's "
                    "tolerance, with no missed contact",
            "config": asdict(config), "figures": figures}
        if log is not None:
            log(f"{pair.key}: {serve} (auto {figures['speedup_n1']:.2f}x at N = 1, "
                f"{figures['speedup_batch']:.2f}x at N = {figures['poses']})")
    return manifest
