"""Issue item 10: a pick whose learned path misses the scene's tolerance on a pair is decided
exact-only for that pair, saying which figure missed which limit, and the validation gate then
passes: it judges what the bundle serves (the exact solver's answers there), not a learned path
that is never served. Through :func:`impactnet.training.jobs.retrain.run_train_job`, the path of
``impactnet train --out`` and ``impactnet sweep --show --out``."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models import load_predictor
from impactnet.models.bundle.store import current_version
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.scenes import load_scene
from impactnet.training.bench.learned import decide as dc
from impactnet.training.jobs import decisions, retrain
from impactnet.training.jobs.retrain import JobConfig, run_train_job
from impactnet.training.jobs.scene import quick_config

#: Two box pairs at the issue's tolerance (1 deg, 0.02 of the shortest edge).
SCENE_TOML = """
[scene]
name = "two_pairs"
description = "Two box pairs at quay_crane's tolerance."
depth_fraction = [0.0, 0.01]

[accuracy]
normal_deg = 1.0
point_fraction = 0.02

[bodies.cube]
size = [2.0, 2.0, 2.0]
description = "The paper's cube."

[bodies.crate]
size = [3.0, 1.5, 1.2]
description = "A crate."

[[pairs]]
a = "cube"
b = "cube"
description = "The paper's pair."

[[pairs]]
a = "crate"
b = "cube"
description = "A crate against the cube."
"""
#: The pair whose learned path misses, and the p99 point errors of the issue (fraction of the
#: shortest edge): 0.0206 on the held-out test split, 0.0268 on the gate's fresh rows (the
#: served check that refused a quick sweep's pick, seed 1, before this change).
MISSED_PAIR = "crate/cube"
MISSES = {"held-out": ("held-out auto p99 point 0.0206 > tolerance 0.02 (fraction of the "
                       "shortest edge)"),
          "fresh-row": ("fresh-row auto p99 point 0.0268 > tolerance 0.02 (fraction of the "
                        "shortest edge)")}
#: A speed-up that meets the speed rule (2x), so that accuracy alone decides here (the
#: measured timings are the machine's: not what this test is about).
FAST = 10.0


@pytest.fixture(scope="module")
def scene_and_cache(tmp_path_factory):
    folder = tmp_path_factory.mktemp("served")
    (folder / "two_pairs.toml").write_text(SCENE_TOML)
    return load_scene(folder / "two_pairs.toml"), folder / "cache"


def _fast(measure):
    def measure_pair(*args, **kwargs):
        return measure(*args, **kwargs) | {"speedup_n1": FAST, "speedup_batch": FAST}
    return measure_pair


def _miss_held_out(build):
    def build_manifest(*args, **kwargs):
        manifest = build(*args, **kwargs)
        manifest["pairs"][MISSED_PAIR]["test"]["auto"]["point_fraction"]["p99"] = 0.0206
        return manifest
    return build_manifest


def _miss_fresh_rows(measure, scene):
    def served_figures(auto, manifest, scene_, index, rows):
        figures = measure(auto, manifest, scene_, index, rows)
        if scene.pairs[index].key == MISSED_PAIR:
            figures["point_fraction"] = {"p99": 0.0268}
        return figures
    return served_figures


@pytest.mark.parametrize("where", list(MISSES))
def test_a_pick_missing_the_tolerance_on_a_pair_serves_it_exact_only_and_publishes(
        scene_and_cache, tmp_path, monkeypatch, where):
    scene, cache = scene_and_cache
    monkeypatch.setattr(dc, "measure_pair", _fast(dc.measure_pair))
    if where == "held-out":
        monkeypatch.setattr(retrain, "build_manifest", _miss_held_out(retrain.build_manifest))
    else:  # what the decision sees; the gate's own served check measures for itself
        monkeypatch.setattr(decisions, "served_figures",
                            _miss_fresh_rows(decisions.served_figures, scene))
    outcome = run_train_job(scene, tmp_path / "store", quick_config(3),
                            JobConfig(cache_dir=cache), progress=False)
    assert outcome.gate.passed and outcome.gate.failures == []
    assert outcome.published and current_version(tmp_path / "store") == outcome.version
    decision = outcome.manifest["pairs"][MISSED_PAIR]["decision"]
    assert decision["serve"] == "exact-only" and decision["reasons"] == [MISSES[where]]
    checks = {c["what"]: c for c in outcome.gate.checks}
    for what in ("served auto p99 normal (deg)", "served auto p99 point (fraction of edge)",
                 "served contact flags differing from exact"):  # the exact answers, checked
        check = checks[f"{MISSED_PAIR} {what}"]
        assert check["met"] and not check.get("informative")
    learned = outcome.manifest["pairs"]["cube/cube"]["decision"]
    assert (learned["serve"], learned["reasons"]) == ("learned", [])  # fast and within
    assert not checks["cube/cube auto p99 point (fraction of edge)"].get("informative")


def test_the_published_bundle_answers_the_exact_only_pair_with_the_exact_solver(
        scene_and_cache, tmp_path, monkeypatch):
    scene, cache = scene_and_cache
    monkeypatch.setattr(dc, "measure_pair", _fast(dc.measure_pair))
    monkeypatch.setattr(retrain, "build_manifest", _miss_held_out(retrain.build_manifest))
    outcome = run_train_job(scene, tmp_path / "store", quick_config(3),
                            JobConfig(cache_dir=cache), progress=False)
    assert read_bundle(outcome.path).pairs[MISSED_PAIR].serve == "exact-only"
    crate, cube = (scene.size(name)[None] for name in ("crate", "cube"))
    level = np.array([[1.0, 0.0, 0.0, 0.0]])
    answer = load_predictor("auto", tmp_path / "store")(  # the cube 1 cm into the crate's top
        crate, np.zeros((1, 3)), level, cube, np.array([[0.0, 0.0, 1.59]]), level)
    assert bool(answer.colliding[0]) and list(answer.predictor) == ["exact"]
