"""`impactnet train`: the learned models of every pair of a scene, written as one bundle.

Stages of :func:`train_scene`:

1. The pairs of the scene are trained by :func:`impactnet.training.fit.pair.train_pair`, in up to
   ``workers`` processes at once (each with one torch thread: the machine has 2 cores and one
   pair's tiny matrix products do not scale across threads). Every pair's result depends only
   on the seed, the pair and the config, never on the worker or the order.
2. The tensors and manifest entries of all pairs are merged into one manifest (the contract in
   docs/learned_predictors.md: scene name and hash, training config, seeds, per-pair blocks
   with the ``auto`` thresholds and the validation and test figures, the test figures of all
   pairs pooled against the goals (:mod:`impactnet.training.evaluate.scene_figures`), the rebuild
   command).
3. :func:`impactnet.models.bundle.format.write_bundle` (the inference side's writer) checks that the
bundle
   reads back and writes it atomically.

``quick`` (:func:`quick_config`): tiny data and few epochs, a few seconds per pair, for tests.
"""
from __future__ import annotations

import hashlib
import multiprocessing
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import safetensors.numpy
import torch
from tqdm import tqdm

from impactnet.models.learned.bundle_loader import write_bundle
from impactnet.models.scenes import Scene
from impactnet.training.data.pair_cache import PairCache, plain
from impactnet.training.data.pair_data import PairDataConfig
from impactnet.training.evaluate.scene_figures import pooled_figures
from impactnet.training.fit.committee import CommitteeConfig
from impactnet.training.fit.loop import FitConfig
from impactnet.training.fit.pair import PairResult, PairTrainConfig, train_pair
from impactnet.training.fit.single import SingleConfig
from impactnet.training.jobs.decisions import record_decisions

#: Wall-clock budget of the default scene's training on the 2-core machine (issue 4), seconds.
SCENE_BUDGET_S = 30 * 60


@dataclass(frozen=True)
class TrainConfig:
    """A scene's training run."""

    pair: PairTrainConfig = field(default_factory=PairTrainConfig)  # what every pair gets
    workers: int = 2  # pairs trained in parallel processes (one torch thread each)
    quick: bool = False  # the quick mode (recorded in the manifest and the rebuild command)


def quick_config(seed: int = 0) -> TrainConfig:
    """Tiny data and epochs: a few seconds per pair, the same files (tests, smoke runs)."""
    fit = FitConfig(batch_size=128, steps_per_epoch=20, max_epochs=3, patience=2,
                    val_rows=1024)
    pair = PairTrainConfig(seed=seed, data=PairDataConfig(rows=6000, min_region_rows=30),
                           single=SingleConfig(hidden=(16, 16), fit=fit),
                           committee=CommitteeConfig(expert_hidden=(16, 16),
                                                     members=2, expert_fit=fit))
    return TrainConfig(pair=pair, workers=1, quick=True)


def train_log(message: str) -> None:
    print(f"train: {message}", file=sys.stderr, flush=True)


def _pair_job(scene: Scene, index: int, config: PairTrainConfig,
              progress: bool | None) -> PairResult:
    """Worker entry point: one pair, one torch thread."""
    torch.set_num_threads(1)
    return train_pair(scene, index, config, progress)


def _train_missing(scene: Scene, config: TrainConfig, indices: list[int], progress: bool | None,
                   done: Callable[[int, PairResult], None]) -> None:
    """Train the pairs ``indices``; ``done(index, result)`` as each one finishes."""
    workers = max(1, min(config.workers, len(indices)))
    if workers == 1:
        for index in indices:
            done(index, train_pair(scene, index, config.pair, progress))
        return
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(workers, mp_context=context) as pool:
        futures = {pool.submit(_pair_job, scene, index, config.pair, False): index
                   for index in indices}
        for future in as_completed(futures):
            done(futures[future], future.result())


def _reuse(scene: Scene, config: TrainConfig, indices: list[int], sources: list,
           reused: dict[str, str] | None) -> dict[int, PairResult]:
    """The pairs of ``indices`` that a source (cache, then bundle) has: index -> result."""
    results = {}
    for index in indices:
        for source in sources:
            hit = source.get(scene, index, config.pair)
            if hit is not None:
                results[index] = hit
                if reused is not None:
                    reused[hit.key] = source.label
                train_log(f"{hit.key} unchanged (same sizes, data and training settings): reused "
                     f"from {source.label}")
                break
    return results


def train_pairs(scene: Scene, config: TrainConfig, progress: bool | None = None,
                pairs: list[int] | None = None, cache: PairCache | None = None,
                reused: dict[str, str] | None = None, reuse: bool = True,
                bundle=None) -> list[PairResult]:
    """Train the pairs ``pairs`` (default: all) of a scene, in scene order of the result.

    With a ``cache`` (:class:`impactnet.training.data.pair_cache.PairCache`), a pair whose entry
    exists is reused instead of trained (said on stderr, and ``reused[key]`` names where it came
    from), and every trained pair is stored as soon as it finishes: an interrupted run loses at most
    the pairs in progress, and its rerun resumes from the finished ones with the same result. A
    ``bundle`` (:class:`impactnet.training.jobs.bundle_reuse.BundleSource`) is asked for the pairs
    that the cache lacks; what it gives is not cached. ``reuse=False`` trains every pair and only
    refreshes the cache.
    """
    indices = list(range(len(scene.pairs))) if pairs is None else list(pairs)
    scene.require_box_pairs("train_pairs", indices)  # no box models of compound bodies
    show = sys.stderr.isatty() if progress is None else progress
    sources = [s for s in (cache, bundle) if s is not None] if reuse else []
    results = _reuse(scene, config, indices, sources, reused)
    missing = [i for i in indices if i not in results]
    with tqdm(total=len(missing), desc=f"train {scene.name}", unit="pair", disable=not show,
              file=sys.stderr, dynamic_ncols=True) as bar:
        def done(index: int, result: PairResult) -> None:
            results[index] = result
            if cache is not None:
                cache.put(scene, index, config.pair, result)
            test = result.block["test"]
            bar.set_postfix_str(f"{result.key}: region acc {test['region_accuracy']:.3f}, "
                                f"fallback {test['auto']['fallback_share']:.3f}")
            bar.update(1)
            train_log(f"{result.key} done in {result.seconds:.0f} s")

        if missing:
            _train_missing(scene, config, missing, progress, done)
    return [results[i] for i in indices]


def rebuild_command(scene: Scene, out, seed: int, quick: bool) -> str:
    """The command line that rebuilds the bundle."""
    return (f"impactnet train --scene {scene.name} --out {Path(out).as_posix()} --seed {seed}"
            + (" --quick" if quick else ""))


def build_manifest(scene: Scene, results: list[PairResult], config: TrainConfig, out,
                   tensors: dict, seconds: float) -> dict:
    """The bundle manifest (without ``files``, which ``write_bundle`` adds)."""
    from impactnet import __version__

    weights_hash = hashlib.sha256(safetensors.numpy.save(tensors)).hexdigest()
    now = datetime.now(UTC)
    seed = config.pair.seed
    return {
        "version": f"{scene.name}-{now:%Y%m%dT%H%M%SZ}-{weights_hash[:8]}",
        "created_utc": now.isoformat(timespec="seconds"),
        "impactnet_version": __version__,
        "scene": {"name": scene.name, "hash": scene.hash()},
        "rebuild_command": rebuild_command(scene, out, seed, config.quick),
        "seeds": {"data": seed, "torch": seed},
        "training": {"config": plain(config), "torch_version": torch.__version__,
                     "seconds": round(seconds, 1)},
        "mlps": {name: spec for r in results for name, spec in r.mlps.items()},
        "pairs": {r.key: r.block for r in results},
        "figures": {"test": pooled_figures([r.test_rows for r in results])},
    }


def train_scene(scene: Scene, out, config: TrainConfig | None = None,
                progress: bool | None = None) -> tuple[Path, dict]:
    """Train every pair of ``scene``, measure each pair's learned path against the exact
    solver and record the decision (:mod:`impactnet.training.jobs.decisions`), and write the
    bundle folder ``out``.

    Returns
    -------
    path : Path
        The bundle folder.
    manifest : dict
        What was written (with ``files``).
    """
    config = config or TrainConfig()
    start = time.perf_counter()
    results = train_pairs(scene, config, progress)
    tensors = {k: v for r in results for k, v in r.tensors.items()}
    manifest = build_manifest(scene, results, config, out, tensors,
                              time.perf_counter() - start)
    manifest = record_decisions(scene, manifest, tensors, config.quick, train_log)
    path = write_bundle(out, manifest, tensors)
    from impactnet.models.learned.bundle_loader import read_bundle

    return path, read_bundle(path).manifest
