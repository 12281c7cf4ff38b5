"""`impactnet reproduce-paper`: the paper's Tables 1 and 2 and Figures 5 and 6, reproduced.

Stages, for each of the two problems (with / without discontinuities,
:mod:`impactnet.training.paper.data`):

1. Data: training, validation and external test sets of the paper's sizes, from one seeded
   stream of the paper's protocol (``numpy.random.default_rng([seed, problem index])``).
2. Screening: the paper tuned the learning rate and momentum; here a small grid of both is
   trained for a short budget (early-stopped on the *validation* set, never the test set), and
   the pair with the lowest validation loss wins.
3. Final: the winning pair trained from the same seed with the full epoch budget, early-stopped
   on the validation set, best weights restored.
4. Evaluation on all three sets (:mod:`impactnet.training.paper.metrics`).
5. Diagnostic (:mod:`impactnet.training.paper.diagnostics`): the Table 2 network on wider families
of
   regions, to show how far a single region is from the paper's Table 2.

The report itself is written by :mod:`impactnet.training.paper.report`.

Torch runs on one thread with deterministic algorithms, so a seed gives the same numbers.
"""
from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.training.paper import data as pdata
from impactnet.training.paper import metrics as pm
from impactnet.training.paper.diagnostics import DiagnosticsConfig, run_diagnostics
from impactnet.training.paper.mlp import MLPConfig, PaperTrainConfig, train

#: The paper's Tables 1 and 2, as printed (radians; rows ME, MAE, RMSE).
PAPER_TABLES = {
    "with_discontinuities": {
        "training": {"ME": -0.0008, "MAE": 0.2765, "RMSE": 0.5410},
        "cross_validation": {"ME": 0.0031, "MAE": 0.2883, "RMSE": 0.5748},
        "external_validation": {"ME": 0.0467, "MAE": 0.4523, "RMSE": 0.7302},
    },
    "without_discontinuities": {
        "training": {"ME": 0.0332, "MAE": 0.4161, "RMSE": 0.6947},
        "cross_validation": {"ME": 0.0259, "MAE": 0.4383, "RMSE": 0.7363},
        "external_validation": {"ME": -0.0005, "MAE": 0.5624, "RMSE": 0.8667},
    },
}
SET_NAMES = ("training", "cross_validation", "external_validation")


@dataclass
class ProblemConfig:
    key: str  # "with_discontinuities" or "without_discontinuities" (JSON key, file names)
    title: str  # heading in the report
    sizes: tuple[int, int, int]  # training / validation / external test patterns
    hidden: tuple[int, int]  # hidden layer widths (the paper's architecture)
    region_only: bool  # True: restricted to paper_data.CANONICAL_REGION


def paper_problems() -> tuple[ProblemConfig, ProblemConfig]:
    """The two problems with the paper's set sizes and architectures."""
    return (ProblemConfig("with_discontinuities", "Table 1: with discontinuities",
                          (8_000, 5_000, 75_000), (20, 18), False),
            ProblemConfig("without_discontinuities", "Table 2: without discontinuities",
                          (10_000, 6_000, 50_000), (20, 17), True))


@dataclass
class ReproduceConfig:
    seed: int = 0  # seeds the data streams ([seed, problem index]) and torch (seed)
    quick: bool = False  # small sets and few epochs (a smoke run, same files)
    problems: tuple[ProblemConfig, ...] = field(default_factory=paper_problems)  # the two problems
    data: pdata.PaperDataConfig = field(default_factory=pdata.PaperDataConfig)  # cube, depths
    learning_rates: tuple[float, ...] = (0.003, 0.01, 0.03)  # screening grid: SGD step sizes
    momenta: tuple[float, ...] = (0.5, 0.9)  # screening grid: SGD momentum constants
    screen: PaperTrainConfig = field(default_factory=lambda: PaperTrainConfig(
        max_epochs=80, patience=25))  # budget of each screening run (lr, momentum overridden)
    final: PaperTrainConfig = field(default_factory=lambda: PaperTrainConfig(
        max_epochs=1000, patience=80, time_limit_s=150.0))  # budget of the final runs
    plot_patterns: int = 200  # external-test patterns shown in Figures 5 and 6
    diagnostics: DiagnosticsConfig = field(default_factory=DiagnosticsConfig)  # wider families


def quick_config(seed: int = 0) -> ReproduceConfig:
    """A smoke-sized configuration (well under a minute): same stages, same files."""
    full = paper_problems()
    return ReproduceConfig(
        seed=seed, quick=True,
        problems=tuple(dataclasses.replace(p, sizes=(800, 500, 2_000)) for p in full),
        data=pdata.PaperDataConfig(chunk=20_000),
        learning_rates=(0.01, 0.03), momenta=(0.9,),
        screen=PaperTrainConfig(max_epochs=5, patience=5),
        final=PaperTrainConfig(max_epochs=30, patience=10, time_limit_s=20.0),
        plot_patterns=100,
        diagnostics=DiagnosticsConfig(draws=30_000, sizes=(300, 200, 300),
                                      train=PaperTrainConfig(max_epochs=5, patience=5)))


@contextlib.contextmanager
def deterministic_torch():
    """One CPU thread and deterministic kernels for the block; previous settings restored."""
    threads, det = torch.get_num_threads(), torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.set_num_threads(threads)
        torch.use_deterministic_algorithms(det)


def _log(message: str) -> None:
    print(f"reproduce-paper: {message}", file=sys.stderr, flush=True)


def make_data(problem: ProblemConfig, index: int, config: ReproduceConfig) -> dict:
    """The three sets of one problem, with how they were drawn."""
    rng = np.random.default_rng([config.seed, index])
    n = sum(problem.sizes)
    if problem.region_only:
        data, stats = pdata.region_set(n, rng, config.data)
        info = {"region_stats": dataclasses.asdict(stats)}
    else:
        data, info = pdata.stream(n, rng, config.data), {}
    codes, counts = np.unique(data.contact_type_code, return_counts=True)
    info["contact_types"] = {CONTACT_TYPES[c]: int(k) for c, k in zip(codes, counts)}
    info["regions"] = int(len({(a, b, c) for a, b, c in zip(
        data.contact_type_code, data.feature_a, data.feature_b)}))
    info["seed"] = [config.seed, index]
    return {"sets": pdata.split(data, problem.sizes), "info": info}


def fit_problem(problem: ProblemConfig, sets: dict, config: ReproduceConfig) -> dict:
    """Screen the (learning rate, momentum) grid, then train the winner with the full budget."""
    mlp = MLPConfig(hidden=problem.hidden)
    tr, va = sets["training"], sets["cross_validation"]
    grid = []
    for lr in config.learning_rates:
        for mom in config.momenta:
            tc = dataclasses.replace(config.screen, learning_rate=lr, momentum=mom,
                                     seed=config.seed)
            run = train(tr.inputs, tr.targets, va.inputs, va.targets, mlp, tc)
            grid.append({"learning_rate": lr, "momentum": mom, "val_loss": run.best_val_loss,
                         "best_epoch": run.best_epoch, "epochs": run.epochs_run,
                         "seconds": run.seconds})
            _log(f"{problem.key}: screen lr={lr:g} momentum={mom:g} -> validation loss "
                 f"{run.best_val_loss:.4f} ({run.epochs_run} epochs, {run.seconds:.1f} s)")
    best = min(grid, key=lambda g: g["val_loss"] if np.isfinite(g["val_loss"]) else np.inf)
    final_cfg = dataclasses.replace(config.final, learning_rate=best["learning_rate"],
                                    momentum=best["momentum"], seed=config.seed)
    model = train(tr.inputs, tr.targets, va.inputs, va.targets, mlp, final_cfg)
    _log(f"{problem.key}: final lr={best['learning_rate']:g} momentum={best['momentum']:g}: "
         f"best epoch {model.best_epoch} of {model.epochs_run}, validation loss "
         f"{model.best_val_loss:.4f}, {model.seconds:.1f} s")
    return {"model": model, "grid": grid, "train_config": dataclasses.asdict(final_cfg),
            "architecture": f"6x{problem.hidden[0]}x{problem.hidden[1]}x4",
            "n_parameters": model.n_parameters(),
            "stopped_by": model.stopped_by}


def evaluate_problem(problem: ProblemConfig, sets: dict, fit: dict, config) -> dict:
    """Metrics of every set, plus the series that Figures 5 and 6 plot."""
    size = np.full(3, config.data.edge)
    out, predictions = {}, {}
    for name in SET_NAMES:
        s = sets[name]
        predictions[name] = fit["model"].predict(s.inputs)
        out[name] = pm.evaluate(predictions[name], s.targets, size, s.point)
    k = min(config.plot_patterns, len(sets["external_validation"]))
    figure = {"desired": sets["external_validation"].targets[:k, 0].tolist(),
              "predicted": predictions["external_validation"][:k, 0].tolist()}
    return {"metrics": out, "figure": figure}


def reproduce(config: ReproduceConfig) -> dict:
    """Run every stage for both problems; returns everything the report shows."""
    start = time.perf_counter()
    results = {"config": dataclasses.asdict(config), "problems": {},
               "versions": {"numpy": np.__version__, "torch": torch.__version__}}
    with deterministic_torch():
        for index, problem in enumerate(config.problems):
            t0 = time.perf_counter()
            data = make_data(problem, index, config)
            t_data = time.perf_counter() - t0
            _log(f"{problem.key}: data {problem.sizes} in {t_data:.1f} s")
            fit = fit_problem(problem, data["sets"], config)
            t1 = time.perf_counter()
            evaluation = evaluate_problem(problem, data["sets"], fit, config)
            results["problems"][problem.key] = {
                "title": problem.title, "sizes": list(problem.sizes),
                "data": data["info"], **evaluation,
                **{k: v for k, v in fit.items() if k != "model"},
                "best_epoch": fit["model"].best_epoch, "epochs_run": fit["model"].epochs_run,
                "history": fit["model"].history,
                "timings_s": {"data": t_data,
                              "screening": sum(g["seconds"] for g in fit["grid"]),
                              "final_training": fit["model"].seconds,
                              "evaluation": time.perf_counter() - t1}}
        diag, ref_key = config.diagnostics, "without_discontinuities"
        if diag.enabled and ref_key in results["problems"]:
            ref = results["problems"][ref_key]
            hidden = next(p.hidden for p in config.problems if p.key == ref_key)
            t0 = time.perf_counter()
            results["diagnostics"] = {
                "rows": run_diagnostics(diag, config.data, config.seed, hidden,
                                        ref["train_config"]["learning_rate"],
                                        ref["train_config"]["momentum"], _log),
                "architecture": ref["architecture"], "seed": [config.seed, 2],
                "sizes": list(diag.sizes), "draws": diag.draws,
                "seconds": time.perf_counter() - t0}
    results["total_seconds"] = time.perf_counter() - start
    return results
