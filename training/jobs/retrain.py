"""Retraining jobs: a scene's pairs into a new version of a bundle store, behind a validation gate.

Stages of :func:`run_train_job`:

1. Store: ``out`` becomes (or is) a bundle store (:mod:`impactnet.models.bundle.store`); a plain
bundle
   folder written before stores existed is adopted as its first version.
2. Pairs: :func:`impactnet.training.jobs.scene.train_pairs` with the store's per-pair cache
   (:mod:`impactnet.training.data.pair_cache`, ``<out>/.cache/pairs`` by default): a pair whose
   sizes, data settings, training config, seed and training code are unchanged is reused (said on
   stderr), the others are trained, and each finished pair is cached at once. A rerun after Ctrl-C
   or a killed process therefore resumes from the finished pairs, and since every pair's training is
   deterministic for its seed, the result equals that of an uninterrupted run. A pair the cache
   lacks (a fresh clone ships the store without its cache) is taken from the store's current bundle
   where it is unchanged there (:mod:`impactnet.training.jobs.bundle_reuse`: same sizes, depth
   range, accuracy, training config, impactnet version and bundle format), said as
   ``reused from bundle <version>``.
3. Decide, then gate: each pair's decision (:mod:`impactnet.training.jobs.decisions`): its learned
   path measured against the exact solver, served only where it is fast enough and within the
   scene's tolerance, else exact-only. Then
   :func:`impactnet.training.fit.validation_gate.validation_gate` and
   :func:`~impactnet.training.fit.validation_gate.served_checks` on the new manifest judge what it
   serves (a learned pair's learned path, an exact-only pair's exact answers); the verdict is stored
   in the manifest (``validation_gate``).
4. Write: the bundle goes to ``versions/<version>/`` when it passed (or the gate is not
   enforced), else to ``rejected/<version>/``, atomically
   (:func:`impactnet.models.bundle.format.write_bundle`).
5. Publish: a passed bundle is loaded as the service would (``load_predictor("auto")``), then
   the ``current`` pointer moves to it atomically. Nothing before this step touches
   ``current``: a failed, rejected or interrupted job leaves the previous version serving.
6. Prune: all but the newest :attr:`JobConfig.keep_versions` versions (the current one always
   stays) and :attr:`JobConfig.keep_rejected` rejected ones are deleted.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

from impactnet.models.bundle.format import MANIFEST, BundleError
from impactnet.models.bundle.store import (
    REJECTED,
    VERSIONS,
    adopt_plain_bundle,
    current_version,
    prune,
    set_current,
)
from impactnet.models.learned.bundle_loader import read_bundle, write_bundle
from impactnet.models.predictors import load_predictor
from impactnet.models.scenes import Scene
from impactnet.training.data.pair_cache import PairCache
from impactnet.training.fit.validation_gate import (
    GateConfig,
    GateResult,
    served_checks,
    validation_gate,
)
from impactnet.training.jobs.bundle_reuse import open_current
from impactnet.training.jobs.decisions import record_decisions
from impactnet.training.jobs.scene import TrainConfig, build_manifest, train_log, train_pairs

#: Default cache folder inside a store (hidden: not a version, not part of the served bundle).
CACHE_SUBDIR = Path(".cache") / "pairs"
#: Accepted versions kept by default: the current one and four to roll back to.
KEEP_VERSIONS = 5
#: Rejected versions kept by default, to inspect why the gate refused them.
KEEP_REJECTED = 2


@dataclass(frozen=True)
class JobConfig:
    """What a retraining job does around the training itself."""

    reuse: bool = True  # reuse unchanged pairs from the cache or the current bundle (False:
    # retrain all; the cache is still refreshed)
    cache_dir: Path | None = None  # per-pair cache folder; None: <out>/.cache/pairs
    gate: GateConfig = field(default_factory=GateConfig)  # the validation gate's bounds
    enforce_gate: bool = True  # False (--no-gate): publish even a bundle that fails the gate
    keep_versions: int = KEEP_VERSIONS  # accepted versions kept after the job (>= 1)
    keep_rejected: int = KEEP_REJECTED  # rejected versions kept after the job (>= 1)


@dataclass
class JobOutcome:
    """What a job did."""

    version: str  # the new version's name (its folder name and manifest ``version``)
    path: Path  # the new version's folder (under versions/ or rejected/)
    manifest: dict  # the new bundle's manifest, as written
    gate: GateResult  # the validation gate's verdict
    published: bool  # ``current`` now names the new version
    previous: str | None  # the version ``current`` named before the job
    reused: list[str] = field(default_factory=list)  # pair keys reused (cache or bundle)
    reused_from: dict[str, str] = field(default_factory=dict)  # pair key -> cache folder or
    # "bundle <version>"
    pruned: list[str] = field(default_factory=list)  # versions deleted by pruning


def _unique_version(store: Path, version: str) -> str:
    """``version``, with a counter appended where a folder of that name exists already."""
    name, n = version, 1
    while (store / VERSIONS / name).exists() or (store / REJECTED / name).exists():
        n += 1
        name = f"{version}-{n}"
    return name


def _adopt_legacy(store: Path) -> None:
    """Stage 1 for a plain bundle folder: it becomes the store's first version."""
    if not (store / MANIFEST).is_file():
        return
    try:
        version = str(read_bundle(store).version)
    except BundleError:
        version = "legacy"
    adopt_plain_bundle(store, _unique_version(store, version))


def _publish(store: Path, path: Path, version: str) -> None:
    """Stage 5: the new version loads as the service loads it, then ``current`` moves; a
    version that does not load is moved to ``rejected/`` and the error raised."""
    try:
        load_predictor("auto", path)
    except BundleError:
        (store / REJECTED).mkdir(exist_ok=True)
        os.rename(path, store / REJECTED / version)
        raise
    set_current(store, version)


def decide_and_gate(scene: Scene, manifest: dict, tensors: dict, quick: bool, job: JobConfig,
                    log=None) -> tuple[dict, GateResult]:
    """Stage 3 of the module docstring: ``manifest`` with each pair's decision and the gate's
    verdict (also stored in it as ``validation_gate``), and the verdict.

    The decisions come first, so that the gate judges what the bundle serves: a pair decided
    exact-only (too slow, or its learned path misses the scene's tolerance) is held to the
    exact solver's served answers, not to its learned path's figures.
    """
    manifest = record_decisions(scene, manifest, tensors, quick, log, job.gate.served_rows)
    gate = validation_gate(manifest, scene, job.gate)
    gate = GateResult.of(gate.checks + served_checks(manifest, tensors, scene, job.gate))
    manifest["validation_gate"] = {**gate.to_dict(), "enforced": job.enforce_gate}
    return manifest, gate


def run_train_job(scene: Scene, out, config: TrainConfig | None = None,
                  job: JobConfig | None = None, progress: bool | None = None,
                  annotate: dict | None = None) -> JobOutcome:
    """Train ``scene`` into a new version of the store ``out`` (see the module docstring).

    ``annotate``: manifest entries to add or replace (a sweep's pick records its study and
    trial there, and its own rebuild command).

    Raises
    ------
    impactnet.models.bundle.format.BundleError
        The new bundle does not read back or load (nothing is published).
    KeyboardInterrupt
        Interrupted: finished pairs are cached, ``current`` is unchanged.
    """
    config, job = config or TrainConfig(), job or JobConfig()
    store = Path(out)
    store.mkdir(parents=True, exist_ok=True)
    _adopt_legacy(store)
    previous = current_version(store)
    cache = PairCache(job.cache_dir if job.cache_dir is not None else store / CACHE_SUBDIR)
    bundle = open_current(store, config.pair) if job.reuse else None
    start, reused = time.perf_counter(), {}
    results = train_pairs(scene, config, progress, cache=cache, reused=reused, reuse=job.reuse,
                          bundle=bundle)
    tensors = {k: v for r in results for k, v in r.tensors.items()}
    manifest = build_manifest(scene, results, config, out, tensors, time.perf_counter() - start)
    manifest["training"]["reused_pairs"] = list(reused)
    manifest["training"]["reused_from"] = dict(reused)
    manifest.update(annotate or {})
    manifest, gate = decide_and_gate(scene, manifest, tensors, config.quick, job,
                                     train_log if progress is not False else None)
    accepted = gate.passed or not job.enforce_gate
    version = _unique_version(store, manifest["version"])
    manifest["version"] = version
    path = write_bundle(store / (VERSIONS if accepted else REJECTED) / version, manifest,
                        tensors)
    if accepted:
        _publish(store, path, version)
    pruned = prune(store, job.keep_versions) + prune(store, job.keep_rejected, REJECTED)
    return JobOutcome(version, path, read_bundle(path).manifest, gate, accepted, previous,
                      list(reused), dict(reused), pruned)
