"""`impactnet evaluate`: every predictor of a bundle on held-out rows, against issue 4's goals.

Stages of :func:`evaluate`:

1. Load the bundle (checksums verified) and every predictor by ``models.load_predictor``, on
   the bundle's learned models (its per-pair decisions lifted: an exact-only pair is evaluated
   as its models answer it; the report lists what is served); a learned name the bundle cannot
   serve is reported as not available, not fatal.
2. Per body pair of the scene: fresh labelled test rows (:mod:`impactnet.training.evaluate.data`; a
   random stream no training run uses), each row's distance to the nearest region boundary,
   then each predictor on all rows in one call (timed), and per-row errors against the exact
   labels (:mod:`impactnet.training.evaluate.metrics`). Per-pair figures are kept.
3. Pooled over the scene: the same figures on all rows, contact-type confusions, the most
   frequent region confusions, errors per boundary-distance bin, error CDFs.
4. The paper's four-angle metric on the paper's protocol (:mod:`impactnet.training.evaluate.paper`)
   for the predictors that cover the paper's cube pair.
5. Issue 4's goals (:data:`GOALS`), each with its measured value and met / missed.

The report, JSON and figures are written by :func:`write`
(:mod:`impactnet.training.evaluate.report`, :mod:`impactnet.training.evaluate.plots`). Everything is
vectorised over rows; loops run over pairs, predictors and distance bins only.
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from impactnet.models.bundle.store import resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.learned.pair_dispatch import UnsupportedPairError
from impactnet.models.predictors import PREDICTOR_NAMES, BundleError, load_predictor
from impactnet.models.scenes import Scene
from impactnet.training.bench.methods import lift_decisions
from impactnet.training.evaluate import metrics as em
from impactnet.training.evaluate.data import (
    INPUTS,
    boundary_distance,
    datagen_config,
    held_out_rows,
)
from impactnet.training.evaluate.paper import cube_pair, paper_metric

#: Format name and version of ``evaluation.json``.
FORMAT, FORMAT_VERSION = "impactnet-evaluation", 1
#: Test rows per pair of ``--quick`` (a smoke run of a few seconds).
QUICK_ROWS = 2_000
#: The paper's external test sizes (with / without discontinuities, as in the reproduction).
PAPER_ROWS = (75_000, 50_000)
#: Paper rows per problem of ``--quick``.
QUICK_PAPER_ROWS = (2_000, 2_000)
#: A region mismatch closer than this to a region boundary (fraction of e) counts as "near a
#: boundary" in the mismatch breakdown.
NEAR_BOUNDARY = 1e-3
#: Issue 4's goals: (goal, predictor, where in the results, bound, "<=" or ">=", unit).
GOALS = (
    ("region accuracy", "committee", ("pooled", "predictors", "committee", "region_accuracy"),
     0.98, ">=", "share"),
    ("normal error median", "committee", ("pooled", "predictors", "committee", "normal_deg",
                                          "median"), 0.2, "<=", "deg"),
    ("normal error mean", "committee", ("pooled", "predictors", "committee", "normal_deg",
                                        "mean"), 1.0, "<=", "deg"),
    ("point error median", "committee", ("pooled", "predictors", "committee", "point_pct",
                                         "median"), 0.5, "<=", "% of e"),
    ("point error mean", "committee", ("pooled", "predictors", "committee", "point_pct",
                                       "mean"), 1.5, "<=", "% of e"),
    ("normal error p99", "auto", ("pooled", "predictors", "auto", "normal_deg", "p99"), 1.0,
     "<=", "deg"),
    ("point error p99", "auto", ("pooled", "predictors", "auto", "point_pct", "p99"), 2.0,
     "<=", "% of e"),
    ("fallback share", "auto", ("pooled", "predictors", "auto", "fallback_share"), 0.10, "<=",
     "share"),
    ("paper wrapped MAE", "committee", ("paper", "problems", "with_discontinuities",
                                        "predictors", "committee", "wrapped", "MAE"), 0.03,
     "<=", "rad"),
    ("paper wrapped MAE", "auto", ("paper", "problems", "with_discontinuities", "predictors",
                                   "auto", "wrapped", "MAE"), 0.03, "<=", "rad"),
)


@dataclass(frozen=True)
class EvaluateConfig:
    """What `impactnet evaluate` measures, and on how much data."""

    rows: int = 100_000  # held-out test rows per body pair
    seed: int = 0  # seed of the test rows (drawn from a stream training never uses)
    predictors: tuple[str, ...] = PREDICTOR_NAMES  # predictors measured, exact first
    paper_rows: tuple[int, int] = PAPER_ROWS  # paper protocol rows: with / without discont.
    quick: bool = False  # a smoke run (recorded in the report)

    def __post_init__(self) -> None:
        if self.rows < 1 or self.seed < 0 or min(self.paper_rows) < 1:
            raise ValueError(f"rows and paper_rows must be >= 1 and seed >= 0, got rows="
                             f"{self.rows}, seed={self.seed}, paper_rows={self.paper_rows}")
        unknown = set(self.predictors) - set(PREDICTOR_NAMES)
        if unknown:
            raise ValueError(f"unknown predictors {sorted(unknown)}; known: {PREDICTOR_NAMES}")


def quick_config(seed: int = 0, rows: int | None = None) -> EvaluateConfig:
    """The ``--quick`` configuration: :data:`QUICK_ROWS` rows per pair (or ``rows``)."""
    return EvaluateConfig(rows=rows or QUICK_ROWS, seed=seed, paper_rows=QUICK_PAPER_ROWS,
                          quick=True)


def _log(message: str) -> None:
    print(f"evaluate: {message}", file=sys.stderr, flush=True)


def load_predictors(bundle, names) -> tuple[dict, dict]:
    """Predictors by name and ``{name: None or the reason it is not available}``."""
    predictors, missing = {}, {}
    for name in names:
        try:
            predictors[name] = load_predictor(name, bundle)
            missing[name] = None
        except BundleError as exc:
            missing[name] = str(exc)
    return predictors, missing


def _run_pair(predictors: dict, data: dict) -> tuple[dict, dict, dict]:
    """Row records, seconds and "not covered" reasons of every predictor on one pair's rows."""
    records, seconds, uncovered = {}, {}, {}
    inputs = [data[k] for k in INPUTS]
    for name, predictor in predictors.items():
        start = time.perf_counter()
        try:
            contacts = predictor(*inputs)
        except UnsupportedPairError as exc:
            uncovered[name] = str(exc)
            continue
        seconds[name] = time.perf_counter() - start
        records[name] = em.row_record(contacts, data, name)
    return records, seconds, uncovered


def _figures(records: dict, distance: np.ndarray, tolerance, group=None, names=None) -> dict:
    """Summaries, confusions and the mismatch breakdown of each predictor's records."""
    return {
        "predictors": {name: em.summaries(r) for name, r in records.items()},
        "type_confusion": {name: em.type_confusion(r) for name, r in records.items()},
        "top_confusions": {name: em.top_confusions(r, group, names)
                           for name, r in records.items() if r.region_pred is not None},
        "mismatches": {name: em.mismatch_breakdown(r, distance, tolerance, NEAR_BOUNDARY)
                       for name, r in records.items() if r.region_pred is not None},
    }


def _pooled(per_pair: list[dict], names: list[str], tolerance, seconds: dict) -> dict:
    """Figures of all pairs' rows together, for the predictors that cover every pair."""
    order = [n for n in PREDICTOR_NAMES if all(n in p["records"] for p in per_pair)]
    records = {n: em.RowRecord.concat([p["records"][n] for p in per_pair]) for n in order}
    distance = {k: np.concatenate([p["distance"][k] for p in per_pair])
                for k in ("distance", "sat_margin")}
    group = np.concatenate([np.full(len(p["distance"]["distance"]), p["index"])
                            for p in per_pair])
    out = _figures(records, distance["distance"], tolerance, group, names)
    for name in order:
        out["predictors"][name]["pairs_per_s"] = (len(records[name].colliding) / seconds[name]
                                                  if seconds.get(name) else None)
    out["boundary"] = {k: em.by_boundary(records, v) for k, v in distance.items()}
    out["cdf"] = {n: {k: em.error_quantiles(records[n], k) for k in ("normal_deg", "point_pct")}
                  for n in order}
    out["excluded"] = [n for p in per_pair for n in p["uncovered"] if n not in order]
    out["excluded"] = sorted(set(out["excluded"]))
    return out


def _lookup(results: dict, path: tuple):
    """The value at ``path`` in nested dicts, or None where any step is missing."""
    value = results
    for part in path:
        if not isinstance(value, dict) or part not in value:
            return None
        value = value[part]
    return value


def check_goals(results: dict) -> list[dict]:
    """Each goal of :data:`GOALS` with its measured value (None: not measured) and whether it is
    met (a goal not measured is missed)."""
    out = []
    for goal, predictor, path, bound, sense, unit in GOALS:
        value = _lookup(results, path)
        met = value is not None and (value >= bound if sense == ">=" else value <= bound)
        out.append({"goal": goal, "predictor": predictor, "value": value, "bound": bound,
                    "sense": sense, "unit": unit, "met": bool(met)})
    return out


def _pair_block(scene: Scene, index: int, predictors: dict, config: EvaluateConfig,
                datagen, tolerance) -> dict:
    """Test rows, boundary distances, row records and figures of one pair."""
    data = held_out_rows(scene, index, config.rows, config.seed, datagen)
    distance = boundary_distance(data)
    records, seconds, uncovered = _run_pair(predictors, data)
    figures = _figures(records, distance["distance"], tolerance)
    figures.pop("type_confusion")
    return {"index": index, "records": records, "distance": distance, "seconds": seconds,
            "uncovered": uncovered,
            "figures": {"rows": config.rows, "edge_m": data["edge"], **figures,
                        "not_covered": uncovered}}


def _paper(scene: Scene, predictors: dict, config: EvaluateConfig) -> dict:
    """The paper's metric for exact, committee and auto, or why it was skipped."""
    key = cube_pair(scene)
    if key is None:
        return {"skipped": "the scene has no pair of the paper's cubes (edge 2 m)"}
    chosen = {n: p for n, p in predictors.items() if n in ("exact", "committee", "auto")}
    try:
        return {"pair": key, **paper_metric(chosen, config.seed, config.paper_rows)}
    except UnsupportedPairError as exc:
        return {"skipped": f"the bundle does not cover the cube pair: {exc}"}


def evaluate(scene: Scene, bundle_path, config: EvaluateConfig, log=_log) -> dict:
    """Every figure of the evaluation (module docstring); ``log`` gets progress lines.

    ``bundle_path`` is a bundle folder or a bundle store (its ``current`` version is read).

    Raises
    ------
    impactnet.models.bundle.format.BundleError
        The bundle is missing, altered or malformed, or belongs to another scene.
    """
    start = time.perf_counter()
    bundle = read_bundle(resolve_bundle(bundle_path))  # a store reads its current version
    bundle_scene = bundle.manifest.get("scene", {})
    if bundle_scene.get("name") != scene.name:
        raise BundleError(f"bundle {bundle_path} was trained for scene "
                          f"{bundle_scene.get('name')!r}, not {scene.name!r}")
    # the models themselves, decisions lifted
    predictors, missing = load_predictors(lift_decisions(bundle), config.predictors)
    datagen = datagen_config(bundle.manifest)
    tolerance = (scene.accuracy.normal_deg, 100.0 * scene.accuracy.point_fraction)
    per_pair, seconds = [], dict.fromkeys(predictors, 0.0)
    for index, pair in enumerate(scene.pairs):
        block = _pair_block(scene, index, predictors, config, datagen, tolerance)
        for name, value in block["seconds"].items():
            seconds[name] += value
        per_pair.append(block)
        log(f"{pair.key}: {config.rows} rows, " + ", ".join(
            f"{n} {block['figures']['predictors'][n]['region_accuracy'] or 0:.3f}"
            for n in block["records"] if block["records"][n].region_pred is not None)
            + " region accuracy")
    names = [p.key for p in scene.pairs]
    results = {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "scene": {"name": scene.name, "hash": scene.hash()},
        "bundle": {"path": str(bundle_path), "version": bundle.version,
                   "scene_hash": bundle_scene.get("hash"),
                   "scene_matches": bundle_scene.get("hash") == scene.hash()},
        "config": {**asdict(config), "datagen": asdict(datagen)},
        "tolerance": {"normal_deg": tolerance[0], "point_pct": tolerance[1]},
        "predictors": missing,
        "pairs": {names[b["index"]]: b["figures"] for b in per_pair},
        "decisions": {key: (bundle.manifest["pairs"].get(key) or {}).get("decision")
                      for key in names},
        "pooled": _pooled(per_pair, names, tolerance, seconds),
    }
    log("paper protocol")
    results["paper"] = _paper(scene, predictors, config)
    results["goals"] = check_goals(results)
    results["goals_met"] = all(g["met"] for g in results["goals"])
    results["seconds"] = time.perf_counter() - start
    return results


def write(results: dict, out) -> list[Path]:
    """``report.md``, ``evaluation.json`` and the figures into the folder ``out``."""
    from impactnet.training.evaluate import plots as evaluate_plots
    from impactnet.training.evaluate import report as evaluate_report

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = evaluate_plots.write_all(results, out)
    json_path = out / "evaluation.json"
    json_path.write_text(json.dumps(results, indent=1, allow_nan=False) + "\n",
                         encoding="utf-8")
    report = out / "report.md"
    report.write_text(evaluate_report.markdown(results, [p.name for p in paths]),
                      encoding="utf-8")
    return [report, json_path, *paths]
