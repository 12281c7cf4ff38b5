"""Everything learned for one body pair: data, single, committee, calibration, figures.

Stages of :func:`train_pair` (one process, one torch thread, deterministic kernels):

1. Data (:func:`impactnet.training.data.pair_data.make_pair_data`): labelled rows, train / val /
test split,
   region classes.
2. ``single`` (:func:`impactnet.training.fit.single.train_single`).
3. Committee: the experts of every region together
   (:func:`impactnet.training.fit.committee.train_experts`); the region classifier is the exact
   labeller, nothing to train.
4. Export to the contract's tensors and run them with the inference side's NumPy MLPs on the
   validation rows (:mod:`impactnet.training.fit.pair_eval`); calibrate ``auto`` there
   (:mod:`impactnet.training.fit.calibrate`).
5. The same on the test rows, only measured (nothing is chosen on them).

Torch seeds: each component draws from a generator seeded by the pair's seed sequence
(``impactnet.training.data.datagen.pair_seed``) with its own stream (:data:`TORCH_STREAMS`), so
pairs and components are independent of the order in which they are trained.
"""
from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from impactnet.models.metrics import summarise
from impactnet.models.scenes import BodyPair, Scene
from impactnet.training.data.datagen import DatagenConfig, pair_seed
from impactnet.training.data.pair_data import PairData, PairDataConfig, make_pair_data, stream
from impactnet.training.evaluate.scene_figures import pooling_record
from impactnet.training.fit.calibrate import (
    CALIBRATION_MARGIN,
    CalibrationTarget,
    auto_keep,
    calibrate,
    calibration_scores,
)
from impactnet.training.fit.committee import (
    CommitteeConfig,
    export_committee,
    train_experts,
)
from impactnet.training.fit.pair_eval import (
    MISMATCH_REPORTED,
    build_mlps,
    committee_metrics,
    evaluate_rows,
)
from impactnet.training.fit.single import SingleConfig, train_single

#: Spawn-key suffixes (under the pair's seed) of the torch generators of each component.
TORCH_STREAMS = {"single": 2_000_001, "experts": 2_000_003}


@dataclass(frozen=True)
class PairTrainConfig:
    """Everything that decides what a pair's models become (recorded in the manifest)."""

    seed: int = 0  # data seed and torch seed base of every pair
    data: PairDataConfig = field(default_factory=PairDataConfig)  # rows and splits
    datagen: DatagenConfig = field(default_factory=DatagenConfig)  # orientation families
    single: SingleConfig = field(default_factory=SingleConfig)  # the single MLP
    committee: CommitteeConfig = field(default_factory=CommitteeConfig)  # the experts


@dataclass
class PairResult:
    """A trained pair: its tensors, manifest entries and record."""

    key: str  # "a/b"
    tensors: dict  # name -> float32 array, every MLP of the pair
    mlps: dict  # manifest "mlps" entries of the pair's networks
    block: dict  # manifest "pairs[key]" entry
    seconds: float  # wall-clock time of the pair
    # per-row test errors (impactnet.training.evaluate.scene_figures.pooling_record), for pooling
    test_rows: dict


@contextlib.contextmanager
def deterministic_torch(threads: int = 1):
    """``threads`` CPU threads and deterministic kernels for the block; settings restored."""
    old_threads, old_det = torch.get_num_threads(), torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(threads)
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.set_num_threads(old_threads)
        torch.use_deterministic_algorithms(old_det)


def torch_generator(seed: np.random.SeedSequence, component: str) -> torch.Generator:
    """The seeded torch generator of one component of a pair."""
    state = stream(seed, TORCH_STREAMS[component]).generate_state(2, dtype=np.uint32)
    return torch.Generator().manual_seed(int(state[0]) << 31 | int(state[1]) >> 1)


def _auto_metrics(pred: dict, scores: np.ndarray, thresholds: dict) -> dict:
    """Fallback share and the errors of ``auto`` (fallback rows answered exactly: error 0)."""
    keep = auto_keep(scores, thresholds)
    out = {"fallback_share": float(1.0 - keep.mean())}
    rows = pred["true_contact"] | keep  # a separated row handed to exact has no error
    for name, key in (("normal_deg", "normal_deg"), ("point_fraction", "point")):
        errors = np.where(keep, pred["errors"][key], 0.0)
        out[name] = summarise(np.minimum(errors[rows], MISMATCH_REPORTED[key]))
    return out


def _split_figures(pred: dict, scores: np.ndarray, thresholds: dict) -> dict:
    return {**committee_metrics(pred), "auto": _auto_metrics(pred, scores, thresholds)}


def train_pair(scene: Scene, index: int, config: PairTrainConfig,
               progress: bool | None = None) -> PairResult:
    """Train, export, calibrate and measure the models of ``scene.pairs[index]``."""
    start, cpu_start = time.perf_counter(), time.process_time()
    pair = scene.pairs[index]
    seed = pair_seed(config.seed, pair)
    size_a, size_b = scene.pair_sizes()[index]
    data = make_pair_data(size_a, size_b, seed, scene.depth_fraction, config.data,
                          config.datagen)
    timing = {"data": time.perf_counter() - start}
    prefix = f"p{index}"
    with deterministic_torch():
        t = time.perf_counter()
        single, single_rec = train_single(data, scene.accuracy, config.single,
                                          torch_generator(seed, "single"), progress,
                                          f"{pair.key} single")
        timing["single"] = time.perf_counter() - t
        t = time.perf_counter()
        experts, exp_rec = train_experts(data, scene.accuracy, config.committee,
                                         torch_generator(seed, "experts"), progress,
                                         f"{pair.key} experts")
        timing["experts"] = time.perf_counter() - t
    tensors, mlps, blocks = export_committee(prefix, data.regions, experts, config.committee)
    tensors.update(single.export(0, f"{prefix}_single"))
    mlps[f"{prefix}_single"] = config.single.spec().to_dict()
    t = time.perf_counter()
    block, figures, test_rows = _calibrate_and_measure(data, scene, pair, tensors, mlps,
                                                       blocks, f"{prefix}_single")
    timing["evaluation"] = time.perf_counter() - t
    seconds = time.perf_counter() - start
    block["training"] = {
        "rows": {name: int(len(rows)) for name, rows in data.split.items()},
        "regions_seen": int(len(np.unique(data.keys[data.split["train"]]))),
        "region_classes": len(data.regions),
        "fit": {"single": single_rec.summary(), "experts": exp_rec.summary()},
        "seconds": {k: round(v, 2) for k, v in {**timing, "total": seconds}.items()},
        "cpu_seconds": round(time.process_time() - cpu_start, 2),  # this process's CPU time
    }
    block.update(figures)
    return PairResult(pair.key, tensors, mlps, block, seconds, test_rows)


def _calibrate_and_measure(data: PairData, scene: Scene, pair: BodyPair, tensors: dict,
                           mlps: dict, blocks: dict, single: str) -> tuple[dict, dict, dict]:
    """The pair's manifest block (models, auto), its validation / test figures and the per-row
    test record (:func:`impactnet.training.evaluate.scene_figures.pooling_record`)."""
    models = build_mlps(tensors, mlps)
    target = CalibrationTarget(scene.accuracy.normal_deg * CALIBRATION_MARGIN,
                               scene.accuracy.point_fraction * CALIBRATION_MARGIN)
    figures = {}
    val = evaluate_rows(data, "val", models, blocks, single)
    val_scores = calibration_scores(val, data.depth_fraction)
    calibration = calibrate(val_scores, val["errors"]["normal_deg"], val["errors"]["point"],
                            target)
    thresholds = calibration["thresholds"]
    figures["validation"] = {**_split_figures(val, val_scores, thresholds),
                             "calibration": {k: v for k, v in calibration.items()
                                             if k != "thresholds"}}
    test = evaluate_rows(data, "test", models, blocks, single)
    test_scores = calibration_scores(test, data.depth_fraction)
    figures["test"] = _split_figures(test, test_scores, thresholds)
    block = {"size_a": list(scene.body(pair.a).size), "size_b": list(scene.body(pair.b).size),
             "depth_fraction": list(data.depth_fraction), "single": single,
             "classifier": blocks["classifier"], "experts": blocks["experts"],
             "auto": thresholds}
    return block, figures, pooling_record(test, auto_keep(test_scores, thresholds))

