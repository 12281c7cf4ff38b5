"""Retraining jobs (impactnet.training.jobs.retrain, `impactnet train`): versioned bundles behind a
gate, reuse of unchanged pairs (from the cache, or from the current bundle where there is no cache),
resume after a kill with the same result."""
from __future__ import annotations

import dataclasses
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import safetensors.numpy

from impactnet.models import load_predictor
from impactnet.models.bundle.format import WEIGHTS
from impactnet.models.bundle.store import REJECTED, VERSIONS, current_version, resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.scenes import Accuracy, load_scene, scene_path
from impactnet.training.data.pair_cache import PairCache, reprefix
from impactnet.training.fit.validation_gate import GateConfig, validation_gate
from impactnet.training.jobs.bundle_reuse import open_current
from impactnet.training.jobs.retrain import JobConfig, run_train_job
from impactnet.training.jobs.scene import quick_config, train_pairs
from tests.training.sweep.test_sweep import loose_scene

REPO = Path(__file__).resolve().parents[3]
#: Seconds a killed training run may take to cache its first pair.
FIRST_PAIR_TIMEOUT_S = 120
#: An impossible bound (errors are >= 0): a gate with it always fails.
IMPOSSIBLE = -1.0
#: The slow tests are about reuse and resume, not about whether quick models pass the gate.
NO_GATE = JobConfig(enforce_gate=False)
#: A scene edit: the cube (in one pair, cube/cube) grows along x.
CUBE_EDIT = ("size = [2.0, 2.0, 2.0]", "size = [2.5, 2.0, 2.0]")
#: A scene edit: the first pair (container20/spreader) goes, so every later pair's index moves.
DROP_FIRST_PAIR = ('[[pairs]]\na = "container20"\nb = "spreader"\n'
                   'description = "Spreader lands on / strikes a 20 ft container."\n', "")


def _weights(store: Path) -> dict:
    return safetensors.numpy.load_file(str(resolve_bundle(store) / WEIGHTS))


def _scene_copy(path: Path, *edits: tuple[str, str]) -> Path:
    """A copy of the quay_crane scene file at ``path``, with text edits ``(old, new)``."""
    text = scene_path("quay_crane").read_text()
    for old, new in edits:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def paper_store(tmp_path_factory):
    """A store of quick models of the paper's scene with loose tolerances (quick models are
    not meant to meet the real ones; these tests are about the store and the gate)."""
    folder = tmp_path_factory.mktemp("jobs")
    scene = load_scene(loose_scene(folder))
    outcome = run_train_job(scene, folder / "paper", quick_config(3), progress=False)
    return folder / "paper", outcome, scene


def test_a_job_writes_a_version_and_points_current_at_it(paper_store):
    store, outcome, _ = paper_store
    assert outcome.published and outcome.gate.passed and outcome.previous is None
    assert current_version(store) == outcome.version == outcome.path.name
    assert outcome.path.parent == store / VERSIONS
    assert outcome.manifest["validation_gate"]["passed"] is True
    assert load_predictor("auto", store) is not None


def test_a_published_version_records_each_pairs_measured_decision(paper_store):
    """Issue #21: every pair of the new version carries its decision and the figures behind it,
    and the served bundle honours it (an exact-only pair is answered by the exact solver)."""
    store, outcome, scene = paper_store
    bundle = read_bundle(outcome.path)
    for pair in scene.pairs:
        decision = outcome.manifest["pairs"][pair.key]["decision"]
        figures = decision["figures"]
        assert decision["serve"] in ("learned", "exact-only")
        assert bundle.pairs[pair.key].serve == decision["serve"]
        assert figures["poses"] == decision["config"]["poses_per_pair"]
        assert figures["speedup_n1"] > 0 and figures["speedup_batch"] > 0
        assert 0.0 <= figures["fallback_share"] <= 1.0
        fast = min(figures["speedup_n1"], figures["speedup_batch"]) >= 2.0
        if not fast:
            assert decision["serve"] == "exact-only"


def test_failing_gate_leaves_current_untouched(paper_store):
    store, first, scene = paper_store
    before = current_version(store)
    job = JobConfig(gate=GateConfig(point_fraction=IMPOSSIBLE))
    outcome = run_train_job(scene, store, quick_config(3), job, progress=False)
    assert not outcome.published and not outcome.gate.passed
    assert current_version(store) == before == first.version
    assert outcome.path.parent == store / REJECTED  # kept to inspect, never served
    assert outcome.reused == ["cube/cube"]  # unchanged pair: not retrained
    assert any("point" in line for line in outcome.gate.failures)


def test_gate_checks_the_scene_hash_and_every_pair(paper_store):
    _, outcome, scene = paper_store
    manifest = outcome.manifest
    assert not validation_gate(manifest, load_scene("quay_crane")).passed
    assert validation_gate(manifest, scene).passed
    learned = {**manifest, "pairs": {key: {k: v for k, v in block.items() if k != "decision"}
                                     for key, block in manifest["pairs"].items()}}
    strict = validation_gate(learned, scene, GateConfig(normal_deg=IMPOSSIBLE))
    assert not strict.passed and strict.failures  # a served learned path out of bounds
    served = [c for c in manifest["validation_gate"]["checks"] if " served " in c["what"]]
    assert served and all(c["met"] for c in served)  # the served auto was checked too


def test_cached_pairs_are_renamed_when_a_pair_moves(tmp_path):
    scene = load_scene("paper")
    cache = PairCache(tmp_path)
    result = train_pairs(scene, quick_config(1), False, cache=cache)[0]
    moved = reprefix(result, 0, 7)
    assert all(name.startswith("p7_") for name in moved.mlps)
    assert {k.split(".")[0] for k in moved.tensors} == set(moved.mlps)
    assert moved.block["single"] == "p7_single"
    again = cache.get(scene, 0, quick_config(1).pair)
    for key, value in result.tensors.items():
        np.testing.assert_array_equal(again.tensors[key], value)


def test_a_damaged_cache_entry_is_retrained_not_fatal(tmp_path):
    """Regression: a truncated safetensors file raised safetensors' own error (an Exception,
    not an OSError) out of the cache instead of counting as a miss."""
    scene = load_scene("paper")
    cache = PairCache(tmp_path)
    train_pairs(scene, quick_config(1), False, cache=cache)
    (weights,) = tmp_path.glob("*/tensors.safetensors")
    weights.write_bytes(weights.read_bytes()[:100])
    assert cache.get(scene, 0, quick_config(1).pair) is None
    retrained = train_pairs(scene, quick_config(1), False, cache=cache)[0]
    assert cache.get(scene, 0, quick_config(1).pair) is not None and retrained.tensors


def _cli(scene: Path, store: Path) -> list[str]:
    return [sys.executable, "-m", "impactnet", "train", "--scene", str(scene), "--out",
            str(store), "--seed", "5", "--quick", "--no-progress", "--no-gate"]


def _cached_entries(store: Path) -> list[Path]:
    """Finished cache entries: pathlib's glob also matches the hidden ``.<key>.tmp-*`` folder
    an entry is written in before its rename (a run killed then has cached nothing yet)."""
    return [p for p in store.glob(".cache/pairs/*/entry.json")
            if not p.parent.name.startswith(".")]


@pytest.mark.slow
def test_a_killed_run_resumes_with_the_same_result(tmp_path):
    scene_file = _scene_copy(tmp_path / "scene.toml")
    reference = tmp_path / "reference"
    run_train_job(load_scene(scene_file), reference, quick_config(5), NO_GATE, progress=False)
    store = tmp_path / "store"
    process = subprocess.Popen(_cli(scene_file, store), cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + FIRST_PAIR_TIMEOUT_S
    while not _cached_entries(store):
        assert process.poll() is None and time.monotonic() < deadline, "no pair was cached"
        time.sleep(0.01)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    assert current_version(store) is None  # killed before publishing: nothing is current
    done = subprocess.run(_cli(scene_file, store), cwd=REPO, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    assert "reused from" in done.stderr  # the finished pairs were not trained again
    ref, resumed = _weights(reference), _weights(store)
    assert ref.keys() == resumed.keys()
    for key, value in ref.items():
        np.testing.assert_array_equal(resumed[key], value, err_msg=key)


@pytest.mark.slow
def test_a_scene_edit_retrains_only_the_changed_pair(tmp_path):
    store = tmp_path / "store"
    first = run_train_job(load_scene(_scene_copy(tmp_path / "scene.toml")), store,
                          quick_config(5), NO_GATE, progress=False)
    scene = load_scene(_scene_copy(tmp_path / "edited.toml", CUBE_EDIT))
    second = run_train_job(scene, store, quick_config(5), NO_GATE, progress=False)
    changed = [p.key for p in scene.pairs if "cube" in p.key]
    assert changed == ["cube/cube"]
    assert sorted(second.reused) == sorted(p.key for p in scene.pairs if p.key not in changed)
    assert second.published and second.previous == first.version
    assert current_version(store) == second.version
    assert second.manifest["pairs"]["cube/cube"]["size_a"] == [2.5, 2.0, 2.0]


def _renamed(tensors: dict, old: int, new: int) -> dict:
    """Tensors of pair ``old`` (``p<old>_...``), named as pair ``new``."""
    return {f"p{new}_{k[len(f'p{old}_'):]}": v for k, v in tensors.items()
            if k.startswith(f"p{old}_")}


def test_a_fresh_clone_reuses_unchanged_pairs_from_the_bundle(tmp_path, capsys):
    """No cache (it is not committed): the unchanged pairs come from the current bundle."""
    store, old_scene = tmp_path / "store", load_scene(_scene_copy(tmp_path / "scene.toml"))
    first = run_train_job(old_scene, store, quick_config(5), NO_GATE, progress=False)
    shutil.rmtree(store / ".cache")
    scene = load_scene(_scene_copy(tmp_path / "edited.toml", CUBE_EDIT, DROP_FIRST_PAIR))
    capsys.readouterr()
    second = run_train_job(scene, store, quick_config(5), NO_GATE, progress=False)
    stderr = capsys.readouterr().err
    unchanged = [p.key for p in scene.pairs if p.key != "cube/cube"]
    assert second.reused_from == {key: f"bundle {first.version}" for key in unchanged}
    assert stderr.count(f"reused from bundle {first.version}") == len(unchanged)
    assert "cube/cube not taken from" in stderr and "cube/cube done in" in stderr
    assert second.manifest["pairs"]["cube/cube"]["size_a"] == [2.5, 2.0, 2.0]
    old_weights, new_weights = _weights(first.path), _weights(store)
    old_index = {p.key: i for i, p in enumerate(old_scene.pairs)}
    for index, pair in enumerate(scene.pairs):
        if pair.key in unchanged:  # moved down by one: renamed, bit for bit the same
            assert index == old_index[pair.key] - 1
            expected = _renamed(old_weights, old_index[pair.key], index)
            got = {k: v for k, v in new_weights.items() if k.startswith(f"p{index}_")}
            assert expected and expected.keys() == got.keys()
            for key, value in expected.items():
                np.testing.assert_array_equal(got[key], value, err_msg=key)


def test_bundle_reuse_needs_the_same_training_config_and_scene(tmp_path, capsys):
    scene, store = load_scene("paper"), tmp_path / "store"
    run_train_job(scene, store, quick_config(3), NO_GATE, progress=False)
    source = open_current(store, quick_config(3).pair)
    from_bundle = source.get(scene, 0, quick_config(3).pair)
    cached = PairCache(store / ".cache" / "pairs").get(scene, 0, quick_config(3).pair)
    assert from_bundle.seconds == 0.0 and cached.seconds > 0.0
    assert (from_bundle.mlps, from_bundle.block) == (cached.mlps, cached.block)
    for got, want in ((from_bundle.tensors, cached.tensors),
                      (from_bundle.test_rows, cached.test_rows)):  # rows: re-evaluated
        assert got.keys() == want.keys()
        for key, value in want.items():
            np.testing.assert_array_equal(got[key], value, err_msg=key)
    stricter = dataclasses.replace(scene, accuracy=Accuracy(0.5, 0.02))
    deeper = dataclasses.replace(scene, depth_fraction=(0.0, 0.02))
    assert source.pair_change(stricter, 0) is not None
    assert source.pair_change(deeper, 0) is not None
    assert open_current(store, quick_config(4).pair) is None  # another seed
    shutil.rmtree(store / ".cache")
    capsys.readouterr()
    other_seed = run_train_job(scene, store, quick_config(4), NO_GATE, progress=False)
    assert other_seed.reused == [] and "another training config" in capsys.readouterr().err
    shutil.rmtree(store / ".cache")  # the seed-4 bundle is current and unchanged, but:
    no_reuse = JobConfig(reuse=False, enforce_gate=False)  # --no-reuse
    assert run_train_job(scene, store, quick_config(4), no_reuse, progress=False).reused == []
