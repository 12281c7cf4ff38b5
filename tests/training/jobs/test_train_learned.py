"""`impactnet train --quick` end to end: a bundle the inference side reads and whose predictors
answer; the same seed gives the same weights."""
from __future__ import annotations

import argparse

import numpy as np
import pytest

from impactnet.models import load_predictor
from impactnet.models.bundle.store import resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.scenes import load_scene
from impactnet.training.data.datagen import generate_pairs
from impactnet.training.evaluate.scene_figures import GOALS
from impactnet.training.fit.calibrate import THRESHOLD_NAMES
from impactnet.training.jobs.cli import add_arguments, run
from impactnet.training.jobs.scene import quick_config, train_pairs

SCENE = "paper"
PAIR = "cube/cube"


@pytest.fixture(scope="module")
def quick_bundle(tmp_path_factory):
    out = tmp_path_factory.mktemp("bundle") / SCENE
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--scene", SCENE, "--out", str(out), "--seed", "2", "--quick",
                              "--no-progress"])
    return run(args), out


def test_quick_training_writes_a_bundle_that_reads_back(quick_bundle):
    status, out = quick_bundle
    assert status == 0
    bundle = read_bundle(resolve_bundle(out))  # `out` is a bundle store (current version)
    manifest = bundle.manifest
    scene = load_scene(SCENE)
    assert manifest["scene"] == {"name": SCENE, "hash": scene.hash()}
    assert manifest["rebuild_command"] == (f"impactnet train --scene {SCENE} --out "
                                           f"{out.as_posix()} --seed 2 --quick")
    assert manifest["seeds"] == {"data": 2, "torch": 2}
    assert manifest["training"]["config"]["quick"] is True
    pair = manifest["pairs"][PAIR]
    assert set(pair["auto"]) == set(THRESHOLD_NAMES)
    assert pair["classifier"]["regions"][0] == "none"
    assert set(pair["experts"]) == set(pair["classifier"]["regions"][1:])
    for split in ("validation", "test"):
        figures = pair[split]
        assert 0.0 <= figures["region_accuracy"] <= 1.0
        assert 0.0 <= figures["auto"]["fallback_share"] <= 1.0
        assert {"committee", "single", "auto"} <= set(figures)
    assert bundle.pairs[PAIR].auto is not None
    assert not list((out / "versions").glob(".*"))  # no temporary folder left behind
    goals = manifest["figures"]["test"]["goals"]
    assert set(goals) == set(GOALS)
    assert all(isinstance(goal["met"], bool) for goal in goals.values())


@pytest.mark.parametrize("name", ["single", "committee", "auto"])
def test_predictors_of_the_quick_bundle_answer(quick_bundle, name):
    _, out = quick_bundle
    predictor = load_predictor(name, out)
    size = load_scene(SCENE).size("cube")
    rows = generate_pairs(size, size, 300, 11, progress=False)
    inputs = [rows[k] for k in ("size_a", "position_a", "quaternion_a", "size_b",
                                "position_b", "quaternion_b")]
    contacts = predictor(*inputs)
    assert len(contacts) == 300
    assert np.isfinite(contacts.normal).all() and np.isfinite(contacts.point).all()
    np.testing.assert_allclose(np.linalg.norm(contacts.normal, axis=1), 1.0, atol=1e-5)
    assert set(contacts.predictor) <= {name, "committee", "exact"}


def test_same_seed_same_weights():
    scene = load_scene(SCENE)
    first = train_pairs(scene, quick_config(seed=4), progress=False)[0]
    second = train_pairs(scene, quick_config(seed=4), progress=False)[0]
    assert first.tensors.keys() == second.tensors.keys()
    for key, value in first.tensors.items():
        np.testing.assert_array_equal(value, second.tensors[key], err_msg=key)
    assert first.block["auto"] == second.block["auto"]


def test_a_pair_without_any_region_class_trains_and_answers(tmp_path):
    """Regression: with little data every region fell under ``min_region_rows`` and the expert
    training crashed on zero groups (a sweep trial failed). Such a pair has no experts; its
    committee answers every clipped contact exactly."""
    import dataclasses

    from impactnet.models.box.exact import box_box
    from impactnet.models.learned.bundle_loader import bundle_in_memory
    from impactnet.training.data.pair_data import PairDataConfig
    from impactnet.training.jobs.scene import build_manifest

    scene = load_scene("paper")
    config = quick_config(0)
    config = dataclasses.replace(config, pair=dataclasses.replace(
        config.pair, data=PairDataConfig(rows=3000, min_region_rows=10**9)))
    result = train_pairs(scene, config, False)[0]
    assert result.block["classifier"]["regions"] == ["none"]
    manifest = build_manifest(scene, [result], config, tmp_path, result.tensors, 0.0)
    committee = load_predictor("committee", bundle_in_memory(manifest, result.tensors))
    rows = generate_pairs(np.full(3, 2.0), np.full(3, 2.0), 300, seed=4, progress=False)
    args = [rows[k] for k in ("size_a", "position_a", "quaternion_a", "size_b", "position_b",
                              "quaternion_b")]
    answer, exact = committee(*args), box_box(*args)
    np.testing.assert_allclose(answer.point, exact.point, atol=1e-9)  # all exact
