"""`impactnet bench moe`: the learned path of compound pairs against the exact compound oracle
(issue #21), pair by pair, and its cost against detail.

For every compound pair of the scene (default ``quay_crane_detail``), with the bundle's models
(default: the shipped bundle; recorded decisions lifted, so an exact-only pair's models are
measured too):

* poses: the held-out first-contact rows of the training data (``<data>/<scene>.compound.npz``
  when it matches the scene), else ``rows`` freshly labelled ones;
* accuracy of ``auto`` on those rows against the oracle's labels and the classifiers' coarse regions
  (:func:`impactnet.training.compound.measure.score_chain`);
* speed: oracle and ``auto`` (fallback rows included) at N = 1 (median of single calls) and at
  N = ``poses`` (the rows repeated), in one run, one thread;
* the issue's rule applied to these figures, beside the decision the bundle records.

Cost against detail: the spreader pair with twistlock heads of 8, 32 and 128 sides (the models
of 32 sides; a head is one part at every level, so the same labels apply): oracle, ``auto``
and the classifiers alone, per pose at a batch and at N = 1.
"""
from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from impactnet.models.learned.compound import chain_of
from impactnet.training.bench.markdown import invoked_command
from impactnet.training.bench.timing import machine_info, median_per_call, median_repeated
from impactnet.training.compound.experts import pair_tolerances
from impactnet.training.compound.measure import (
    TimingConfig,
    oracle_call,
    pair_decision,
    score_chain,
    timings,
)
from impactnet.training.compound.rows import pair_columns, split_rows

#: Twistlock head sides of the cost-against-detail measurement.
DETAIL_SIDES = (8, 32, 128)


@dataclass(frozen=True)
class MoeConfig:
    """What ``impactnet bench moe`` measures."""

    scene: str = "quay_crane_detail"  # scene of compound pairs
    bundle: str | None = None  # bundle folder or store (None: models/bundles/<scene>)
    data: str = "data"  # folder of the training data (held-out rows); else labelled here
    rows: int = 2000  # rows labelled per pair when there is no training data
    timing: TimingConfig = TimingConfig(batch_poses=100_000, single_calls=200, warmup=20)
    seed: int = 0  # split seed (the training's) and labelling seed
    http: bool = False  # also the HTTP goals (impactnet.training.bench.http.moe)
    http_requests: int = 500  # single-pair requests per mode (and /healthz requests)
    http_batch: int = 100_000  # spreader poses in the npz batch per mode
    detail_batch: int = 4096  # poses per batch of the cost-against-detail measurement


QUICK = MoeConfig(rows=300, timing=TimingConfig(batch_poses=2000, single_calls=20, warmup=3),
                  http_requests=50, http_batch=500, detail_batch=256)


def _rows(scene, k: int, pair, config: MoeConfig):
    """The pair's labelled rows: the training data's held-out rows, or fresh ones (all)."""
    path = Path(config.data) / f"{scene.name}.compound.json"
    if path.is_file():
        manifest = json.loads(path.read_text(encoding="utf-8"))
        if manifest["scene"]["hash"] == scene.hash():
            rows = split_rows(pair_columns(np.load(Path(config.data) / manifest["npz"]), k),
                              manifest["seed"])
            return rows, "held-out rows of the training data"
    from impactnet.training.data.compound_data import compound_rows

    edge = scene.smaller_shortest_edge(pair)
    data = compound_rows(scene.body(pair.a).parts, scene.body(pair.b).parts, config.rows,
                         tuple(edge * f for f in scene.depth_fraction),
                         np.random.default_rng(config.seed + 1))
    rows = split_rows(data, config.seed)
    return dataclasses.replace(rows, test=np.arange(len(rows))), "freshly labelled rows"


def measure_pair(scene, pair, models, rows, source: str, config: MoeConfig) -> dict:
    """Figures of one pair (module docstring) on its labelled ``rows`` (held out: ``test``)."""
    parts_a, parts_b = scene.body(pair.a).parts, scene.body(pair.b).parts
    out = {"pair": pair.key, "rows": len(rows.test), "poses_from": source,
           "recorded": models.serve if models else None}
    if models is None or not models.classifiers:
        return out | {"measured": None}
    chain = chain_of(models, parts_a, parts_b)
    position, quaternion = rows.position[rows.test], rows.quaternion[rows.test]
    identity = (np.zeros(3), np.array([1.0, 0, 0, 0]))
    figures = score_chain(chain, rows, rows.test, *pair_tolerances(scene, pair))
    speed = timings(oracle_call(parts_a, parts_b),
                    lambda p, q: chain.answer(*identity, p, q), position, quaternion,
                    config.timing)
    serve, reasons = pair_decision(figures, speed)
    return out | {"measured": figures | speed, "decision": serve, "reasons": reasons}


def detail_costs(scene, models, rows, config: MoeConfig) -> list[dict]:
    """Oracle, auto and the classifiers alone against the twistlock heads' sides."""
    from impactnet.models.compound import crane_bodies as cb
    from impactnet.models.geometry.rotations import quaternion_to_matrix

    parts_a = scene.body("container40").parts
    batch = config.detail_batch
    position = np.resize(rows.position[rows.test], (batch, 3))
    quaternion = np.resize(rows.quaternion[rows.test], (batch, 4))
    out = []
    for sides in DETAIL_SIDES:
        parts_b = cb.spreader("40ft", sides=sides)
        chain = chain_of(models, parts_a, parts_b)
        oracle = oracle_call(parts_a, parts_b)
        identity = (np.zeros(3), np.array([1.0, 0, 0, 0]))

        def auto(p, q, chain=chain):
            return chain.answer(*identity, p, q)

        rotation = quaternion_to_matrix(quaternion)
        singles = [(position[i], quaternion[i]) for i in range(config.timing.single_calls)]
        row = {"sides": sides}
        for name, fn in (("oracle", oracle), ("auto", auto)):
            row[f"{name}_batch_us"] = median_repeated(lambda fn=fn: fn(position, quaternion),
                                                      1) / batch * 1e6
            row[f"{name}_n1_us"] = median_per_call(fn, singles, config.timing.warmup)[0] * 1e6
        row["classifier_batch_us"] = median_repeated(
            lambda: chain.candidates(position, rotation), 1) / batch * 1e6
        row["classifier_n1_us"] = median_per_call(
            lambda p, r: chain.candidates(p, r),
            [(position[i:i + 1], rotation[i:i + 1]) for i in range(config.timing.single_calls)],
            config.timing.warmup)[0] * 1e6
        out.append(row)
    return out


def run(config: MoeConfig, out: str | None = None, plot: str | None = None) -> dict:
    """Measure every compound pair and the cost against detail; write moe.md, moe.json and the
    plot into ``out`` when given."""
    from impactnet.models.bundle.store import resolve_bundle
    from impactnet.models.learned.bundle_loader import read_bundle
    from impactnet.models.predictors import DEFAULT_BUNDLE
    from impactnet.models.scenes import load_scene
    from impactnet.training.bench.learned.moe_report import plot_detail, report
    from impactnet.training.data.compound_dataset import compound_pairs

    start = time.perf_counter()
    scene = load_scene(config.scene)
    folder = config.bundle or DEFAULT_BUNDLE.parent / scene.name
    bundle = read_bundle(resolve_bundle(folder))
    pairs, detail, http = [], [], None
    for k, pair in enumerate(compound_pairs(scene)):
        models = bundle.compound.get(pair.key)
        rows, source = _rows(scene, k, pair, config)
        pairs.append(measure_pair(scene, pair, models, rows, source, config))
        if pair.key != "container40/spreader":
            continue
        if models is not None and models.classifiers:
            detail = detail_costs(scene, models, rows, config)
        if config.http:
            from impactnet.training.bench.http.moe import measure_http

            http = measure_http(config.scene, config.bundle, rows.position[rows.test],
                                rows.quaternion[rows.test], config.http_requests,
                                config.http_batch)
    result = {"scene": scene.name, "command": invoked_command("impactnet bench moe"),
              "version": bundle.version, "config": dataclasses.asdict(config),
              "machine": machine_info(), "pairs": pairs, "detail": detail, "http": http,
              "seconds": time.perf_counter() - start}
    text = report(result)
    print(text)
    if out:
        Path(out).mkdir(parents=True, exist_ok=True)
        (Path(out) / "moe.md").write_text(text + "\n", encoding="utf-8")
        (Path(out) / "moe.json").write_text(json.dumps(result, indent=2, default=str) + "\n",
                                            encoding="utf-8")
        if detail:
            plot_detail(detail, plot or Path(out) / "moe_cost_vs_detail.png")
    return result
