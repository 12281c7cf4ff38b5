"""Probe: one classifier for the four corners, pooled through the bodies' mirror symmetries
(issue #21's "canonical frame where the bodies' symmetries allow one"), against one classifier
per corner. A measurement of the design that ``ClassifierConfig.pooled`` trains.

The crane bodies are symmetric under the mirrors x -> -x and y -> -y (checked here part by
part: every part maps to a part with the mirrored bounds). Corner ``c``'s rows are mapped into
corner ``fl``'s frame by its mirror ``M`` (``fr``: y, ``al``: x, ``ar``: both): the offset of
B's group from A's group becomes ``M p``, B's rotation ``M R M`` (a proper rotation), and every
part to its mirror image, so that one classifier sees four times the rows. Both designs are
trained alike (:func:`impactnet.training.bench.learned.classifier_probe.train_classifier`, the same
epochs), split alike (70 / 15 / 15 %), and scored per corner on the held-out rows: the exact
set at 0.5, and the recall design of the served chain: a candidate floor of
:data:`SAFETY` times the least probability of a touching validation label, with the rows that
then miss a touching pair and the candidates per row.

    python -m impactnet.training.bench.learned.classifier_pooled --pair container40/spreader \\
        --data SPREADER.npz          # the labelled rows (classifier_probe's cache)
"""
from __future__ import annotations

import time

import numpy as np

from impactnet.models.geometry.rotations import quaternion_to_matrix
from impactnet.models.learned.compound.groups import CORNER_MIRRORS, mirror_map
from impactnet.models.scenes import load_scene
from impactnet.training.bench.learned.classifier_probe import (
    CORNERS,
    SPLIT,
    _corner_inputs,
    label_matrix,
    labelled_rows,
    probe_arguments,
    train_classifier,
)

#: The served chain's candidate floor: this share of the least sure touching validation label.
SAFETY = 0.1


def _mirrored(data: dict, pair: str, corner: str):
    """Corner ``corner``'s (features (n, 9), canonical keys (c,), rows (c,)) in fl's frame."""
    scene = load_scene("quay_crane_detail")
    a, b = pair.split("/")
    m = np.asarray(CORNER_MIRRORS[corner], float)
    x, keys, pose = _corner_inputs(data, pair, corner)
    rotation = quaternion_to_matrix(data["quaternion_b"]) * m[None, :, None] * m[None, None, :]
    x = np.c_[x[:, :3] * m, rotation[:, :, :2].reshape(len(x), 6)]
    map_a, map_b = mirror_map(scene.body(a).parts, m), mirror_map(scene.body(b).parts, m)
    if map_a is None or map_b is None:
        raise ValueError(f"{pair}: the bodies are not symmetric under the mirror {tuple(m)}")
    return x, map_a[keys // 4096] * 4096 + map_b[keys % 4096], pose


def recall_figures(prob, labels, val, held, unknown) -> dict:
    """Exact sets at 0.5, and at the served floor: rows missing a touching pair, candidates."""
    truth = labels > 0.5
    least = prob[val][truth[val]].min() if truth[val].any() else 0.5
    floor = SAFETY * least
    exact = ((prob[held] > 0.5) == truth[held]).all(axis=1) & ~np.isin(held, unknown)
    missed = (truth[held] & (prob[held] < floor)).any(axis=1) | np.isin(held, unknown)
    return {"exact_set": float(exact.mean()), "floor": float(floor),
            "missed_rows": int(missed.sum()), "candidates": float((prob[held] >= floor)
                                                                  .sum(axis=1).mean())}


def compare(data: dict, pair: str, hidden: int, epochs: int, seed: int) -> dict:
    """Per corner: the per-corner classifier's figures and the pooled one's."""
    n = len(data["push"])
    order = np.random.default_rng(seed).permutation(n)
    train = order[:int(SPLIT[0] * n)]
    val, held = order[int(SPLIT[0] * n):int(SPLIT[1] * n)], order[int(SPLIT[1] * n):]
    out, pooled = {}, []
    start = time.perf_counter()
    for corner in CORNERS:
        x, keys, pose = _corner_inputs(data, pair, corner)
        vocab, labels, unknown = label_matrix(keys, pose, n, train)
        prob = train_classifier(x, labels, train, hidden, epochs, seed)
        out[corner] = {"own": recall_figures(prob, labels, val, held, unknown)}
        pooled.append(_mirrored(data, pair, corner))
    out["seconds_own"] = time.perf_counter() - start
    start = time.perf_counter()
    x = np.concatenate([p[0] for p in pooled])
    keys = np.concatenate([p[1] for p in pooled])
    pose = np.concatenate([p[2] + k * n for k, p in enumerate(pooled)])
    shift = np.arange(len(CORNERS))[:, None] * n
    vocab, labels, unknown = label_matrix(keys, pose, len(CORNERS) * n,
                                          (train[None, :] + shift).ravel())
    prob = train_classifier(x, labels, (train[None, :] + shift).ravel(), hidden, epochs, seed)
    all_val = (val[None, :] + shift).ravel()
    for k, corner in enumerate(CORNERS):
        out[corner]["pooled"] = recall_figures(prob, labels, all_val, held + k * n, unknown)
    out["seconds_pooled"] = time.perf_counter() - start
    out["labels_pooled"] = len(vocab)
    return out


def report(figures: dict) -> str:
    """The comparison as a markdown table."""
    lines = ["| corner | classifier | exact set | candidate floor | held-out rows missing a "
             "touching pair | candidates per row |", "|---|---|---|---|---|---|"]
    for corner in CORNERS:
        for name in ("own", "pooled"):
            f = figures[corner][name]
            lines.append(f"| {corner} | {name} | {f['exact_set']:.2%} | {f['floor']:.2g} | "
                         f"{f['missed_rows']} | {f['candidates']:.2f} |")
    lines.append(f"\ntraining: {figures['seconds_own']:.0f} s per-corner (4 classifiers), "
                 f"{figures['seconds_pooled']:.0f} s pooled ({figures['labels_pooled']} labels)")
    return "\n".join(lines)


def main(argv=None) -> int:
    args = probe_arguments(__doc__.split("\n")[0], 16000).parse_args(argv)
    data = labelled_rows(args.pair, args.rows, args.seed, args.data)
    print(report(compare(data, args.pair, args.hidden, args.epochs, args.seed)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
