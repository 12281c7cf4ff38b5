"""One benchmark run: pose sets, every method on each, the paper check, the speed section
against MuJoCo called from Python (:mod:`impactnet.training.bench.speed.section`), optional
HTTP.

    from impactnet.training.bench.measure import QUICK
    from impactnet.training.bench.runner import run_bench
    results = run_bench(QUICK)          # a dict, the content of results.json

``methods`` may be given (tests add a deliberately perturbed predictor); the first method of
family ``"exact"`` is the reference of every error column and must be present.
"""
from __future__ import annotations

import datetime
import sys
import time
from dataclasses import asdict

from impactnet.training.bench.accuracy import vs_mujoco
from impactnet.training.bench.markdown import invoked_command
from impactnet.training.bench.measure import BenchConfig, add_ratios, measure_method
from impactnet.training.bench.methods import default_methods
from impactnet.training.bench.paper import grid_estimate as paper
from impactnet.training.bench.paper.polygon import RULE, VARIANTS
from impactnet.training.bench.pose_sets import figure2_poses, scene_poses
from impactnet.training.bench.timing import machine_info

#: Seed offset of the Figure 2 placements (independent of the scene poses).
FIGURE2_SEED_OFFSET = 1


def stderr_log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def build_pose_sets(config: BenchConfig, scene) -> list:
    """The scene's first contacts and the Figure 2 hard case."""
    return [scene_poses(scene, config.scene_poses, config.seed),
            figure2_poses(scene, config.figure2_tilts, config.figure2_per_tilt,
                          config.seed + FIGURE2_SEED_OFFSET)]


def mujoco_info(config: BenchConfig) -> dict:
    """Whether the "vs MuJoCo" column is measured, why not, and its targets."""
    note = vs_mujoco.mujoco_missing() if config.mujoco_poses > 0 else \
        "disabled (mujoco_poses = 0)"
    info = {"available": note is None, "note": note, "rows": config.mujoco_poses,
            "normal_deg": vs_mujoco.NORMAL_TOL_DEG,
            "point_pct": 100.0 * vs_mujoco.POINT_TOL_FRACTION}
    if note is None:
        import mujoco

        info["version"] = mujoco.__version__
    return info


def run_bench(config: BenchConfig, methods=None, mode: str = "custom",
              log=stderr_log) -> dict:
    """Measure every method on every pose set; returns the results as plain JSON types."""
    from impactnet.models.scenes import load_scene

    started = time.perf_counter()
    machine = machine_info()
    scene = load_scene(config.scene)
    t0 = time.perf_counter()
    sets = build_pose_sets(config, scene)
    log(f"bench: {', '.join(f'{len(s):,} {s.name}' for s in sets)} poses in "
        f"{time.perf_counter() - t0:.1f} s")
    if methods is None:
        methods = default_methods(config.grid_sizes, config.learned, config.bundle)
    exact = next(m for m in methods if m.family == "exact")
    tolerance = (scene.accuracy.normal_deg, 100.0 * scene.accuracy.point_fraction)
    mujoco = mujoco_info(config)
    rows = []
    for poses in sets:
        reference = exact.batch(poses.args(), False)
        column = vs_mujoco.MujocoColumn(poses, config.mujoco_poses) if mujoco["available"] \
            else None
        for method in methods:
            rows.append(measure_method(method, poses, reference, config, log, tolerance,
                                       column))
    add_ratios(rows)
    results = {
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "mode": mode,
        "command": invoked_command("impactnet bench" + (" --quick" if mode == "quick" else "")),
        "config": asdict(config),
        "machine": machine,
        "scene": {"name": scene.name, "hash": scene.hash(), "pairs": len(scene.pairs),
                  "depth_fraction": list(scene.depth_fraction),
                  "tolerance": {"normal_deg": tolerance[0], "point_pct": tolerance[1]}},
        "pose_sets": {s.name: {"poses": len(s), "description": s.description} for s in sets},
        "polygon_rule": RULE,
        "polygon_variants": VARIANTS,
        "rows": [r.to_dict() for r in rows],
        "paper_estimate": paper.check(rows),
        "mujoco": mujoco,
    }
    if config.speed is not None:
        from impactnet.training.bench.speed.section import measure as measure_speed

        results["speed"] = measure_speed(config.speed, sets[0], config.seed, log)
    if config.http:
        from impactnet.training.bench.http.predictors import measure_http

        results["http"] = measure_http(config, sets[0], scene, log)
    results["seconds"] = round(time.perf_counter() - started, 1)
    return results
