"""`impactnet sweep`: a multi-objective Optuna study of the learned models, over many processes.

What a trial optimises (three objectives, all minimised):

1. ``fallback``: the share of the held-out test rows of the trial's pairs, pooled, that
   ``auto`` sends to the exact solver (its calibrated thresholds find the committee too
   unsure there: the committee's error, as seen by the served mode). The committee's normal
   is exact (its region classifier is the exact labeller), so its normal error is no
   objective;
2. ``point_p99``: 99th percentile of the committee's point error (fraction of the pair's
   shortest edge) on the same rows (colliding rows the committee answers);
3. ``auto_us``: measured wall time of the ``auto`` predictor (NumPy, the served mode:
   committee, exact solver where unsure) per pair, in microseconds, on
   :attr:`SweepConfig.timing_rows` first-contact poses of the trial's pairs (the best of
   :attr:`SweepConfig.timing_repeats` runs). Falling back is where accuracy turns into cost.

A trial trains :attr:`SweepConfig.pair_keys` only (default: the scene's first pair) with the
settings :func:`impactnet.training.sweep.space.suggest` draws; the pick is retrained on every pair
of the scene (:mod:`impactnet.training.sweep.report` and :func:`publish_pick`).

Pruning: Optuna's pruners do not support multi-objective studies, so a trial is pruned by
:func:`hopeless` between its pairs: after pair k its validation ``auto`` fallback share (the
share of rows its committee is too unsure or too wrong for) is compared with what the completed
trials had after pair k; worse than their :attr:`SweepConfig.prune_percentile` percentile, after
:attr:`SweepConfig.prune_startup` completed trials, stops it (state ``PRUNED``). Pruning thus
saves time when trials train several pairs.

Workers: every process (on any machine) runs :func:`run_worker` with the same study name and
storage URL; Optuna's RDB storage is the only coordination. Each worker's heartbeat marks its
running trial alive; a worker killed mid-trial stops beating, and after the grace period the
next trial start of any worker marks that trial ``FAIL`` and queues a retry of its parameters
(``RetryHeartbeatStaleTrialCallback``). A worker stops when ``trials`` trials are complete or
pruned; while other workers still run the last ones it waits (so a dead worker's last trial is
retried, not lost).
"""
from __future__ import annotations

import dataclasses
import os
import shutil
import socket
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from impactnet.models.scenes import Scene
from impactnet.training.data.compound_dataset import compound_pairs
from impactnet.training.data.pair_cache import PairCache
from impactnet.training.evaluate.scene_figures import pooled_figures
from impactnet.training.fit.pair import PairTrainConfig
from impactnet.training.fit.pair_eval import MISMATCH_REPORTED
from impactnet.training.jobs.scene import TrainConfig, build_manifest, quick_config, train_pairs
from impactnet.training.sweep.compound_trial import CompoundObjective
from impactnet.training.sweep.pruning import completed_values, hopeless
from impactnet.training.sweep.space import SweepSpace, quick_space, suggest

#: The objectives, in the order the study stores them (all minimised).
OBJECTIVES = ("fallback", "point_p99", "auto_us")
#: Seed of the timing poses (fixed: every trial is timed on the same poses).
TIMING_SEED = 20_240_601
#: Seconds between two looks at the study while other workers finish the last trials.
WAIT_POLL_S = 1.0
#: Study user attributes that must match when a study is resumed.
IDENTITY_KEYS = ("scene", "scene_hash", "pairs", "quick", "seed")


class SweepError(RuntimeError):
    """A study cannot be run as asked (e.g. resumed with other settings)."""


@dataclass(frozen=True)
class SweepConfig:
    """One sweep worker's settings (the study's identity is checked on resume)."""

    study: str  # study name (resumed by name)
    storage: str  # SQLAlchemy URL: sqlite:///file.sqlite3 or postgresql://user@host/db
    workdir: Path  # per-worker files: the pair cache, temporary trial bundles
    trials: int = 40  # complete + pruned trials the study should reach, over all workers
    pair_keys: tuple[str, ...] = ()  # pairs a trial trains; () = the scene's first pair
    seed: int = 0  # data and torch seed of every trial
    quick: bool = False  # quick base config and space (tests, smoke runs)
    space: SweepSpace | None = None  # None: SweepSpace() or quick_space() by ``quick``
    timing_rows: int = 100_000  # poses the auto predictor is timed on
    timing_repeats: int = 3  # timing runs; the fastest counts
    heartbeat_s: int = 30  # seconds between a running trial's heartbeats
    grace_s: int = 90  # seconds without a heartbeat after which a trial is stale
    max_retry: int = 2  # retries of a stale trial's parameters
    prune_startup: int = 5  # completed trials before pruning starts
    prune_percentile: float = 75.0  # worse than this percentile of completed trials: pruned
    sampler_seed: int | None = None  # TPE seed (None: differs per worker, as it should)

    def resolved_space(self) -> SweepSpace:
        """The search space in use."""
        return self.space or (quick_space() if self.quick else SweepSpace())

    def base(self) -> TrainConfig:
        """The config every trial starts from."""
        if self.quick:
            return quick_config(self.seed)
        return TrainConfig(pair=PairTrainConfig(seed=self.seed), workers=1)


def _log(message: str) -> None:
    print(f"sweep: {message}", file=sys.stderr, flush=True)


def open_study(config: SweepConfig, scene: Scene | None = None):
    """The study of ``config`` (created if new): RDB storage with heartbeat and retries.

    With ``scene`` the study's identity (scene, hash, pairs, quick, seed) is stored on creation
    and checked on resume; without it (``--show``) the study must exist.
    """
    import optuna
    from optuna.storages import RDBStorage, RetryHeartbeatStaleTrialCallback

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    engine = {"pool_pre_ping": True}
    if config.storage.startswith("sqlite"):
        engine["connect_args"] = {"timeout": 60}  # several processes share one file
    with warnings.catch_warnings():  # heartbeat arguments are marked experimental
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        storage = RDBStorage(config.storage, engine_kwargs=engine,
                             heartbeat_interval=config.heartbeat_s, grace_period=config.grace_s,
                             heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(
                                 max_retry=config.max_retry))
    if scene is None:
        try:
            return optuna.load_study(study_name=config.study, storage=storage)
        except KeyError:
            raise SweepError(f"no study {config.study!r} in {public_url(config.storage)}; "
                             "run it first (without --show)") from None
    sampler = optuna.samplers.TPESampler(seed=config.sampler_seed)
    study = optuna.create_study(study_name=config.study, storage=storage, sampler=sampler,
                                directions=["minimize"] * len(OBJECTIVES), load_if_exists=True)
    _check_identity(study, config, scene)
    return study


def trial_pairs(scene: Scene, keys: tuple[str, ...]) -> list[int]:
    """Indices of the pairs a trial trains (``keys`` empty: the first pair)."""
    names = [p.key for p in scene.pairs]
    unknown = [k for k in keys if k not in names]
    if unknown:
        raise SweepError(f"scene {scene.name} has no pair {unknown}; its pairs: {names}")
    return [names.index(k) for k in keys] if keys else [0]


def _check_identity(study, config: SweepConfig, scene: Scene) -> None:
    """Store the study's identity on creation; refuse a resume with other settings."""
    identity = {"scene": scene.name, "scene_hash": scene.hash(),
                "pairs": [scene.pairs[i].key for i in trial_pairs(scene, config.pair_keys)],
                "quick": config.quick, "seed": config.seed,
                "space": config.resolved_space().to_dict(), "objectives": list(OBJECTIVES)}
    stored = study.user_attrs
    if "scene_hash" not in stored:
        for key, value in identity.items():
            study.set_user_attr(key, value)
        return
    differ = [k for k in IDENTITY_KEYS if stored.get(k) != identity[k]]
    if differ:
        raise SweepError(f"study {config.study!r} exists with other settings ("
                         + ", ".join(f"{k}: {stored.get(k)!r} != {identity[k]!r}"
                                     for k in differ)
                         + "); use another --study name or the same settings")


_POSES: dict[tuple, tuple] = {}


def timing_poses(scene: Scene, indices: tuple[int, ...], rows: int) -> tuple:
    """Seeded first-contact poses of the pairs ``indices``, ``rows`` in all (the same for
    every trial; kept per process): the six input arrays of a predictor."""
    from impactnet.training.data.datagen import generate_pairs

    key = (scene.hash(), tuple(indices), rows)
    if key not in _POSES:
        sizes = scene.pair_sizes()
        share = -(-rows // len(indices))
        parts = [generate_pairs(sizes[i][0], sizes[i][1], share, TIMING_SEED + i,
                                progress=False, depth_fraction=scene.depth_fraction)
                 for i in indices]
        names = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
        _POSES[key] = tuple(np.concatenate([p[n] for p in parts])[:rows] for n in names)
    return _POSES[key]


def time_predictor(predictor, poses: tuple, repeats: int) -> float:
    """Microseconds per pair of ``predictor`` on ``poses``: the fastest of ``repeats`` runs."""
    best = float("inf")
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        predictor(*poses)
        best = min(best, time.perf_counter() - start)
    return 1e6 * best / len(poses[0])


def _finite(value, cap: float) -> float:
    """An objective value: ``value``, or ``cap`` where nothing was measured."""
    return cap if value is None or not np.isfinite(value) else float(min(value, cap))


class Objective:
    """A trial: train the trial's pairs, prune between pairs, measure errors and cost."""

    def __init__(self, config: SweepConfig, scene: Scene) -> None:
        self.config, self.scene = config, scene
        self.indices = trial_pairs(scene, config.pair_keys)
        self.base, self.space = config.base(), config.resolved_space()
        self.cache = PairCache(Path(config.workdir) / "cache")

    def __call__(self, trial) -> tuple[float, float, float]:
        import optuna

        start = time.perf_counter()
        trial.set_user_attr("worker", f"{socket.gethostname()}:{os.getpid()}")
        train = dataclasses.replace(self.base, pair=suggest(trial, self.space, self.base.pair))
        results = []
        for step, index in enumerate(self.indices, 1):
            results += train_pairs(self.scene, train, False, [index], cache=self.cache)
            value = results[-1].block["validation"]["auto"]["fallback_share"]
            key = f"step{step}_val_fallback"
            trial.set_user_attr(key, value)
            if hopeless(value, completed_values(trial.study, key), self.config.prune_startup,
                        self.config.prune_percentile):
                raise optuna.TrialPruned(f"validation fallback share {value:.3f} after pair "
                                         f"{step} is worse than the completed trials'")
        attrs = self._measure(train, results, trial.number)
        attrs["seconds"] = round(time.perf_counter() - start, 2)
        for key, value in attrs.items():
            trial.set_user_attr(key, value)
        return tuple(attrs[name] for name in OBJECTIVES)

    def _measure(self, train: TrainConfig, results: list, number: int) -> dict:
        """Test figures of the trial's pairs and the measured cost of its bundle."""
        from impactnet.models.learned.bundle_loader import write_bundle
        from impactnet.models.predictors import load_predictor

        tensors = {k: v for r in results for k, v in r.tensors.items()}
        folder = Path(self.config.workdir) / "trials" / f"{self.config.study}-{number}"
        manifest = build_manifest(self.scene, results, train, folder, tensors, 0.0)
        write_bundle(folder, manifest, tensors)
        try:
            poses = timing_poses(self.scene, tuple(self.indices), self.config.timing_rows)
            costs = {f"{name}_us": time_predictor(load_predictor(name, folder), poses,
                                                  self.config.timing_repeats)
                     for name in ("committee", "auto")}
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        test = pooled_figures([r.test_rows for r in results])
        committee, auto = test["committee"], test["auto"]
        return {
            "fallback": auto["fallback_share"],
            "normal_p99": _finite(committee["normal_deg"]["p99"], MISMATCH_REPORTED["normal_deg"]),
            "point_p99": _finite(committee["point_fraction"]["p99"], MISMATCH_REPORTED["point"]),
            **costs,
            "committee_normal_median": committee["normal_deg"]["median"],
            "committee_point_median": committee["point_fraction"]["median"],
            "auto_normal_p99": auto["normal_deg"]["p99"],
            "auto_point_p99": auto["point_fraction"]["p99"],
            "auto_fallback_share": auto["fallback_share"],
            "pairs": [r.key for r in results],
        }


def state_counts(study) -> dict[str, int]:
    """Trials of the study per state name (``COMPLETE``, ``RUNNING``, ...)."""
    from optuna.trial import TrialState

    counts = {state.name: 0 for state in TrialState}
    for trial in study.get_trials(deepcopy=False):
        counts[trial.state.name] += 1
    return counts


def _fail_stale(study) -> None:
    """Mark trials of dead workers FAIL (and queue their retries) now."""
    import optuna

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        optuna.storages.fail_stale_trials(study)


def _trial_line(trial, counts: dict[str, int], total: int) -> str:
    """One progress line for a finished trial."""
    done = counts["COMPLETE"] + counts["PRUNED"]
    head = f"trial {trial.number} {trial.state.name.lower()}"
    if trial.values:
        head += (f": auto fallback {trial.values[0]:.3f}, point p99 {trial.values[1]:.3g}, "
                 f"auto {trial.values[2]:.3g} us/pair")
    return f"{head} [{done}/{total} done, {counts['RUNNING']} running]"


def run_worker(config: SweepConfig, scene: Scene, max_failures: int = 3) -> list[int]:
    """Run trials of the study until it has ``config.trials`` complete or pruned ones.

    Returns the numbers of the trials this worker ran. While the remaining trials are running
    in other workers it waits for them (a dead worker's trial is then retried here).
    """
    from optuna.trial import TrialState

    study = open_study(config, scene)
    objective = CompoundObjective(config, scene) if compound_pairs(scene) else \
        Objective(config, scene)
    ran, failures = [], 0
    _log(f"study {config.study!r}: {config.trials} trials of {', '.join(study.user_attrs['pairs'])}"
         f" on {public_url(config.storage)}")
    while failures < max_failures:
        _fail_stale(study)
        counts = state_counts(study)
        done = counts["COMPLETE"] + counts["PRUNED"]
        if done >= config.trials:
            break
        if done + counts["RUNNING"] >= config.trials:
            time.sleep(WAIT_POLL_S)  # the last trials run elsewhere: wait for them
            continue
        finished = []
        study.optimize(objective, n_trials=1, catch=(Exception,),
                       callbacks=[lambda _study, trial: finished.append(trial)])
        for trial in finished:
            ran.append(trial.number)
            failures = failures + 1 if trial.state == TrialState.FAIL else 0
            _log(_trial_line(trial, state_counts(study), config.trials))
    if failures >= max_failures:
        raise SweepError(f"{failures} trials in a row failed in this worker; see the errors "
                         "above")
    return ran


def public_url(url: str) -> str:
    """``url`` without its password (for logs and manifests)."""
    from sqlalchemy.engine import make_url

    return make_url(url).render_as_string(hide_password=True)
