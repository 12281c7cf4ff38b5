"""One compound pair's learned path, trained, measured and decided (issue #21).

Stages of :func:`train_compound_pair`:

1. Split the labelled rows (:mod:`impactnet.training.compound.rows`).
2. Fit committees for the regions with the most rows and choose each region's expert
   (:mod:`impactnet.training.compound.experts`).
3. Bound: where no region took a committee, the learned path can at best name exactly the
   touching part pairs and solve them with the exact part-pair solver. That best case (the
   held-out rows' true part pairs, no classifier cost) is timed against the oracle; if it is
   not :data:`SPEEDUP_REQUIRED` x faster at N = 1 and at the batch, no classifier can make the
   pair pay, and it is recorded exact-only without training one.
4. Otherwise train the group classifiers (:mod:`impactnet.training.compound.classify`), run
   the chain on the held-out rows, time it against the oracle and apply the rule
   (:func:`impactnet.training.compound.measure.pair_decision`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from impactnet.models.compound.oracle import part_pair_contacts
from impactnet.models.learned.compound.chain import CompoundChain
from impactnet.models.learned.compound.groups import part_groups
from impactnet.training.bench.timing import median_per_call, median_repeated
from impactnet.training.compound.classify import (
    ClassifierConfig,
    group_entry,
    pooled_maps,
    train_group,
    train_pooled,
)
from impactnet.training.compound.experts import ExpertConfig, fit_regions, pair_tolerances
from impactnet.training.compound.measure import (
    SPEEDUP_REQUIRED,
    TimingConfig,
    oracle_call,
    pair_decision,
    score_chain,
    timings,
)
from impactnet.training.compound.rows import split_rows


@dataclass(frozen=True)
class CompoundTrainConfig:
    """Training of one compound pair."""

    seed: int = 0  # split, weights and batches
    classifier: ClassifierConfig = field(default_factory=ClassifierConfig)  # group classifiers
    experts: ExpertConfig = field(default_factory=ExpertConfig)  # region committees
    timing: TimingConfig = field(default_factory=TimingConfig)  # the decision's timings
    best_case_first: bool = False  # stage 3: skip the classifier where even the best case
    # loses (faster; the pair then has no classifier figures)
    keep_models: bool = True  # keep an exact-only pair's models in the bundle (the bench
    # measures them with the decision lifted;
    # the service still answers the pair with the oracle)


def train_compound_pair(scene, pair, data: dict, config: CompoundTrainConfig,
                        log=print) -> tuple[dict, dict, dict]:
    """(manifest entry, tensors, MLP specs) of one compound pair from its labelled rows."""
    start = time.perf_counter()
    a, b = pair.a, pair.b
    parts_a, parts_b = scene.body(a).parts, scene.body(b).parts
    rows = split_rows(data, config.seed)
    tol, point_tol = pair_tolerances(scene, pair)
    prefix = f"{a}__{b}"
    committees, regions, tensors, specs = fit_regions(rows, parts_a, parts_b, point_tol, tol,
                                                      config.experts, prefix, config.seed)
    log(f"{pair.key}: {len(committees)} of {len(regions)} regions take a committee")
    entry = {"parts_a": [p.name for p in parts_a], "parts_b": [p.name for p in parts_b],
             "regions": regions, "rows": {"train": len(rows.train), "validation": len(rows.val),
                                          "test": len(rows.test)}}
    if not committees and config.best_case_first:
        hopeless = _hopeless(parts_a, parts_b, rows, config.timing)
        if hopeless is not None:
            entry["best_case"] = hopeless["figures"]
            entry["decision"] = hopeless | {"seconds": round(time.perf_counter() - start, 1)}
            log(f"{pair.key}: exact-only ({hopeless['reasons'][0]})")
            return entry, {}, {}
    classifiers, group_entries, t, s = _classifiers(rows, parts_a, parts_b, config, prefix)
    tensors, specs = tensors | t, specs | s
    chain = CompoundChain(pair.key, parts_a, parts_b, tuple(classifiers), committees)

    def auto(position, quaternion):
        return chain.answer(np.zeros(3), np.array([1.0, 0, 0, 0]), position, quaternion)

    test_position, test_quaternion = rows.position[rows.test], rows.quaternion[rows.test]
    figures = score_chain(chain, rows, rows.test, tol, point_tol)
    speed = timings(oracle_call(parts_a, parts_b), auto, test_position, test_quaternion,
                    config.timing)
    serve, reasons = pair_decision(figures, speed)
    entry["groups"] = group_entries
    entry["decision"] = {"serve": serve, "rule": _rule(), "reasons": reasons,
                         "figures": figures | speed,
                         "seconds": round(time.perf_counter() - start, 1)}
    log(f"{pair.key}: {serve} ({'; '.join(reasons) or 'every goal met'})")
    if serve == "exact-only" and not config.keep_models:  # the figures stay, not the models
        entry["groups"] = [{k: v for k, v in g.items() if k == "figures"} | {"name": g["name"]}
                           for g in group_entries]
        return entry, {}, {}
    return entry, tensors, specs


def _classifiers(rows, parts_a, parts_b, config: CompoundTrainConfig, prefix: str):
    """(classifiers, their manifest entries, tensors, specs) of every group of the pair."""
    groups = part_groups(parts_a, parts_b)
    classifiers, entries, tensors, specs = [], [], {}, {}
    maps = pooled_maps(parts_a, parts_b, groups) if config.classifier.pooled else None
    if maps is not None:  # the four corners share one classifier, each through its mirror
        name = f"{prefix}.classifier_corners"
        pooled, tensors, specs, figures = train_pooled(rows, groups, maps, config.classifier,
                                                       name, config.seed)
        classifiers += pooled
        entries += [group_entry(clf, name) | {"figures": figures} for clf in pooled]
    for g in range(len(classifiers), len(groups)):
        name = f"{prefix}.classifier_{groups[g].name}"
        clf, t, s, figures = train_group(rows, groups, g, config.classifier, name,
                                         config.seed + g)
        classifiers.append(clf)
        entries.append(group_entry(clf, name) | {"figures": figures})
        tensors, specs = tensors | t, specs | s
    return classifiers, entries, tensors, specs


def _hopeless(parts_a, parts_b, rows, timing: TimingConfig) -> dict | None:
    """Stage 3: the exact-only decision (with the best case's figures) where even the best
    case is not fast enough, else None."""
    bound = best_case_timings(parts_a, parts_b, rows, timing)
    if min(bound["speedup_n1"], bound["speedup_batch"]) >= SPEEDUP_REQUIRED:
        return None
    reason = (f"even naming exactly the touching part pairs for free, the exact part-pair "
              f"solver is {bound['speedup_n1']:.2f}x the oracle's speed at N = 1 and "
              f"{bound['speedup_batch']:.2f}x at N = {bound['batch_poses']:,}, and no "
              f"region's committee meets the tolerance: no classifier can make this pair pay")
    return {"serve": "exact-only", "rule": _rule(), "reasons": [reason], "figures": bound}


def _rule() -> dict:
    from impactnet.training.compound import measure

    return {"speedup_required": SPEEDUP_REQUIRED, "missed_max": measure.MISSED_MAX,
            "fallback_max": measure.FALLBACK_MAX, "exact_set_min": measure.EXACT_SET_MIN}


def best_case_timings(parts_a, parts_b, rows, config: TimingConfig) -> dict:
    """Oracle against the exact part-pair solver on the true part pairs of the held-out poses
    (no classifier), timed as :func:`impactnet.training.compound.measure.timings` does."""
    test = rows.test
    mine, pose = rows.contacts_of(test)
    part_a, part_b = rows.part_a[mine], rows.part_b[mine]
    order = np.argsort(pose, kind="stable")
    pose, part_a, part_b = pose[order], part_a[order], part_b[order]
    start = np.searchsorted(pose, np.arange(len(test) + 1))

    oracle = oracle_call(parts_a, parts_b)
    identity = np.array([1.0, 0, 0, 0])
    picks = np.linspace(0, len(test) - 1, config.single_calls + config.warmup).astype(int)
    def one(k):
        s = slice(start[k], start[k + 1])
        return part_pair_contacts(parts_a, np.zeros(3), identity, parts_b,
                                  rows.position[test[k]], rows.quaternion[test[k]],
                                  np.zeros(s.stop - s.start, np.int64), part_a[s], part_b[s])

    oracle_one, _ = median_per_call(lambda k: oracle(rows.position[test[k]],
                                                     rows.quaternion[test[k]]),
                                    [(k,) for k in picks], config.warmup)
    best_one, _ = median_per_call(one, [(k,) for k in picks], config.warmup)
    take = np.resize(np.arange(len(test)), config.batch_poses)
    counts = start[take + 1] - start[take]
    rep_pose = np.repeat(np.arange(len(take)), counts)
    src = (np.repeat(start[take], counts) + np.arange(counts.sum())
           - np.repeat(np.cumsum(counts) - counts, counts))
    position, quaternion = rows.position[test[take]], rows.quaternion[test[take]]
    oracle_batch = median_repeated(lambda: oracle(position, quaternion), config.repeats)
    best_batch = median_repeated(lambda: part_pair_contacts(
        parts_a, np.zeros(3), identity, parts_b, position, quaternion, rep_pose, part_a[src],
        part_b[src]), config.repeats)
    n = config.batch_poses
    return {"batch_poses": n, "oracle_n1_us": oracle_one * 1e6,
            "best_case_n1_us": best_one * 1e6,
            "oracle_batch_us_per_pose": oracle_batch / n * 1e6,
            "best_case_batch_us_per_pose": best_batch / n * 1e6,
            "speedup_n1": oracle_one / best_one, "speedup_batch": oracle_batch / best_batch}
