"""Probe: can an MLP name the touching part pairs of a compound pair (issue #21, step 1)?

A measurement, not a predictor: it labels first-contact rows of one pair of
``quay_crane_detail`` with the exact oracle, trains a multi-label MLP classifier (PyTorch) on
70 % of them and reports, on the held-out 15 %, how often the predicted set of touching part
pairs is exact, and what share of rows a confidence margin sends to the oracle to reach a given
exactness (issue #21's goal: exact on >= 99.9 % of the answered rows with <= 10 % fallback).

Two inputs are compared:

* ``global``: B's pose in A's frame (position, first two columns of the rotation), one
  classifier over every part pair seen in training;
* ``local``: one classifier per corner ``c`` (``fl``, ``fr``, ``al``, ``ar``) over the part
  pairs of A's group ``casting_top_<c>`` or B's group ``<B group>_<c>`` (a bottom casting, a
  twistlock head), with the pose of B's group relative to A's group as input.

With ``--experts K`` it also regresses the contact of the K most frequent part pairs (one MLP
each, on the pose of B's part relative to A's part), once over all of a pair's rows and once per
region of the pair (its contact type and the two features: finer than issue #21's coarse
regions, an upper bound of what region experts can reach), once over its largest coarse
region (contact type and the faces of the two parts' bounding boxes that the normal crosses,
:mod:`impactnet.models.learned.compound.regions`: issue #21's granularity), and reports the
p99 errors against the scene's tolerances (normal 1 degree, point
``Scene.point_tolerance_m``, depth 2 % of the depth range).

Usage::

    python -m impactnet.training.bench.learned.classifier_probe --pair container40/spreader \\
        --rows 30000 --data /tmp/spreader.npz      # the labelled rows are cached there
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from impactnet.models.compound.parts import bounds
from impactnet.models.geometry.rotations import quaternion_to_matrix
from impactnet.models.learned.compound.regions import coarse_regions
from impactnet.models.scenes import load_scene
from impactnet.training.data.compound_data import compound_rows

#: Corners of the crane bodies' generated part names.
CORNERS = ("fl", "fr", "al", "ar")
#: B's group per corner, by B's generator: a container's bottom casting, a spreader's head.
B_GROUPS = {"container": "casting_bottom", "spreader": "head"}
#: Confidence margins reported: a row is answered when every label's probability is below the
#: margin or above 1 - margin, else it goes to the oracle.
MARGINS = (0.02, 0.05, 0.1, 0.2)
#: Train / validation split of the rows (the rest is held out).
SPLIT = (0.7, 0.85)


def labelled_rows(pair: str, rows: int, seed: int, cache: Path | None) -> dict:
    """The oracle's rows of ``pair`` (``a/b`` of quay_crane_detail), cached in ``cache``."""
    if cache is not None and cache.exists():
        return dict(np.load(cache))
    scene = load_scene("quay_crane_detail")
    a, b = pair.split("/")
    edge = scene.smaller_shortest_edge((a, b))
    depths = tuple(edge * f for f in scene.depth_fraction)
    data = compound_rows(scene.body(a).parts, scene.body(b).parts, rows, depths,
                         np.random.default_rng(seed))
    if cache is not None:
        np.savez(cache, **data)
    return data


def _centre(parts, group: str) -> np.ndarray:
    lows, highs = zip(*(bounds(p) for p in parts if p.name.split("/")[0] == group))
    return 0.5 * (np.min(lows, axis=0) + np.max(highs, axis=0))


def label_matrix(keys: np.ndarray, pose: np.ndarray, n: int, train: np.ndarray):
    """(vocabulary (v,), labels (n, v) float32, rows with a pair outside the vocabulary)."""
    vocab = np.unique(keys[np.isin(pose, train)])
    labels = np.zeros((n, len(vocab)), np.float32)
    known = np.isin(keys, vocab)
    labels[pose[known], np.searchsorted(vocab, keys[known])] = 1.0
    return vocab, labels, np.unique(pose[~known])


def _features(position, rotation, offset=None):
    """(n, 9): position (plus ``offset`` (n, 3)) and the rotation's first two columns."""
    at = position if offset is None else position + offset
    return np.c_[at, rotation[:, :, :2].reshape(len(at), 6)]


def train_classifier(x, labels, train, hidden: int, epochs: int, seed: int):
    """Probabilities (n, v) of a 3-layer tanh MLP trained with binary cross-entropy."""
    import torch

    mean, std = x[train].mean(axis=0), x[train].std(axis=0) + 1e-9
    xn = torch.tensor(((x - mean) / std).astype(np.float32))
    torch.manual_seed(seed)
    width = x.shape[1]
    net = torch.nn.Sequential(torch.nn.Linear(width, hidden), torch.nn.Tanh(),
                              torch.nn.Linear(hidden, hidden), torch.nn.Tanh(),
                              torch.nn.Linear(hidden, hidden), torch.nn.Tanh(),
                              torch.nn.Linear(hidden, labels.shape[1]))
    optimiser = torch.optim.Adam(net.parameters(), 3e-3)
    steps = max(1, epochs * (len(train) // 256))
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimiser, 3e-3, total_steps=steps)
    x_train, y_train = xn[train], torch.tensor(labels[train])
    for _ in range(steps):
        batch = torch.randint(0, len(train), (256,))
        loss = torch.nn.functional.binary_cross_entropy_with_logits(net(x_train[batch]),
                                                                    y_train[batch])
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        schedule.step()
    with torch.no_grad():
        return torch.sigmoid(net(xn)).numpy()


def set_figures(prob, labels, rows, unknown) -> dict:
    """Exact-set share and, per margin, fallback share, exactness on the answered rows and the
    share of rows answered with a missed contact, over ``rows``."""
    predicted, truth = prob[rows] > 0.5, labels[rows] > 0.5
    exact = (predicted == truth).all(axis=1) & ~np.isin(rows, unknown)
    out = {"exact_set": float(exact.mean()), "margins": {}}
    for margin in MARGINS:
        sure = ((prob[rows] < margin) | (prob[rows] > 1 - margin)).all(axis=1)
        missed = (truth & ~predicted).any(axis=1) & sure
        out["margins"][margin] = {
            "fallback": float(1 - sure.mean()),
            "exact_answered": float(exact[sure].mean()) if sure.any() else 1.0,
            "missed_rows": float(missed.mean())}
    return out


def _corner_inputs(data: dict, pair: str, corner: str):
    """(features (n, 9), part-pair keys (c,), their rows (c,)) of one corner's classifier."""
    scene = load_scene("quay_crane_detail")
    a, b = pair.split("/")
    parts_a, parts_b = scene.body(a).parts, scene.body(b).parts
    b_group = B_GROUPS[scene.body(b).spec["generator"]]
    n = len(data["push"])
    pose = np.repeat(np.arange(n), np.diff(data["contact_offsets"]))
    part_a, part_b = data["contact_part_a"].astype(int), data["contact_part_b"].astype(int)
    groups_a = np.array([parts_a[i].name.split("/")[0] for i in part_a])
    groups_b = np.array([parts_b[j].name.split("/")[0] for j in part_b])
    mine = (groups_a == f"casting_top_{corner}") | (groups_b == f"{b_group}_{corner}")
    rotation = quaternion_to_matrix(data["quaternion_b"])
    offset = (np.einsum("nij,j->ni", rotation, _centre(parts_b, f"{b_group}_{corner}"))
              - _centre(parts_a, f"casting_top_{corner}"))
    return (_features(data["position_b"], rotation, offset), (part_a * 4096 + part_b)[mine],
            pose[mine])


def learning_curve(data: dict, pair: str, sizes, hidden: int, seed: int,
                   corner: str = "fl") -> list[dict]:
    """Corner ``corner``'s classifier trained on the first ``size`` training rows, for each
    size, on the same held-out rows; epochs scaled so that every run takes as many steps."""
    n = len(data["push"])
    x, keys, pose = _corner_inputs(data, pair, corner)
    order = np.random.default_rng(seed).permutation(n)
    held = order[int(SPLIT[1] * n):]
    out = []
    for size in sizes:
        train = order[:size]
        vocab, labels, unknown = label_matrix(keys, pose, n, train)
        epochs = max(60, round(60 * SPLIT[0] * n / size))
        prob = train_classifier(x, labels, train, hidden, epochs, seed)
        out.append({"train_rows": int(size), "labels": len(vocab)}
                   | set_figures(prob, labels, held, unknown))
    return out


def probe(data: dict, pair: str, hidden: int, epochs: int, seed: int) -> dict:
    """The ``global`` and per-corner ``local`` figures (module docstring) of one pair."""
    n = len(data["push"])
    pose = np.repeat(np.arange(n), np.diff(data["contact_offsets"]))
    part_a, part_b = data["contact_part_a"].astype(int), data["contact_part_b"].astype(int)
    keys = part_a * 4096 + part_b
    order = np.random.default_rng(seed).permutation(n)
    train, held = order[:int(SPLIT[0] * n)], order[int(SPLIT[1] * n):]
    rotation = quaternion_to_matrix(data["quaternion_b"])
    vocab, labels, unknown = label_matrix(keys, pose, n, train)
    prob = train_classifier(_features(data["position_b"], rotation), labels, train, hidden,
                            epochs, seed)
    figures = {"rows": n, "global": {"labels": len(vocab)} | set_figures(prob, labels, held,
                                                                         unknown)}
    for corner in CORNERS:
        x, corner_keys, corner_pose = _corner_inputs(data, pair, corner)
        vocab, labels, unknown = label_matrix(corner_keys, corner_pose, n, train)
        prob = train_classifier(x, labels, train, hidden, epochs, seed)
        figures[f"local_{corner}"] = {"labels": len(vocab)} | set_figures(prob, labels, held,
                                                                          unknown)
    return figures


def _regress(x, y, train, test, hidden: int, epochs: int, seed: int) -> np.ndarray:
    """Predictions (len(test), w) of a 2-layer tanh MLP fitted to ``y`` by squared error."""
    import torch

    x_mean, x_std = x[train].mean(axis=0), x[train].std(axis=0) + 1e-9
    y_mean, y_std = y[train].mean(axis=0), y[train].std(axis=0) + 1e-9
    xt = torch.tensor(((x - x_mean) / x_std).astype(np.float32))
    yt = torch.tensor(((y - y_mean) / y_std).astype(np.float32))
    torch.manual_seed(seed)
    net = torch.nn.Sequential(torch.nn.Linear(x.shape[1], hidden), torch.nn.Tanh(),
                              torch.nn.Linear(hidden, hidden), torch.nn.Tanh(),
                              torch.nn.Linear(hidden, y.shape[1]))
    optimiser = torch.optim.Adam(net.parameters(), 3e-3)
    steps = max(1, epochs * (len(train) // 128))
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimiser, 3e-3, total_steps=steps)
    generator = torch.Generator().manual_seed(seed)
    for _ in range(steps):
        batch = torch.from_numpy(train)[torch.randint(0, len(train), (128,),
                                                      generator=generator)]
        loss = ((net(xt[batch]) - yt[batch]) ** 2).mean()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        schedule.step()
    with torch.no_grad():
        return net(xt[test]).numpy() * y_std + y_mean


def expert_figures(data: dict, pair: str, top: int, hidden: int, epochs: int,
                   seed: int) -> list[dict]:
    """p99 errors of per-part-pair and per-region regressors (module docstring)."""
    scene = load_scene("quay_crane_detail")
    a, b = pair.split("/")
    parts_a, parts_b = scene.body(a).parts, scene.body(b).parts
    n = len(data["push"])
    pose = np.repeat(np.arange(n), np.diff(data["contact_offsets"]))
    part_a, part_b = data["contact_part_a"].astype(int), data["contact_part_b"].astype(int)
    region = (data["contact_type"].astype(np.int64) * 2**40
              + data["contact_feature_a"].astype(np.int64) * 2**20 + data["contact_feature_b"])
    rotation = quaternion_to_matrix(data["quaternion_b"])
    depth_tol = 0.02 * scene.smaller_shortest_edge((a, b)) * scene.depth_fraction[1]
    keys, counts = np.unique(part_a * 4096 + part_b, return_counts=True)
    out = []
    for key in keys[np.argsort(-counts)][:top]:
        i, j = divmod(int(key), 4096)
        centre_a, centre_b = (0.5 * np.add(*bounds(p)) for p in (parts_a[i], parts_b[j]))
        point_tol = scene.point_tolerance_m((a, b), parts_a[i].name, parts_b[j].name)
        rows = np.flatnonzero(part_a * 4096 + part_b == key)
        groups = {"part pair": [rows]}
        main_region = np.unique(region[rows], return_counts=True)
        groups["largest region"] = [rows[region[rows] == main_region[0][np.argmax(
            main_region[1])]]]
        coarse = coarse_regions(data["contact_type"], data["contact_normal"], rotation[pose])
        main_coarse = np.unique(coarse[rows], return_counts=True)
        groups["largest coarse region"] = [rows[coarse[rows] == main_coarse[0][np.argmax(
            main_coarse[1])]]]
        entry = {"pair": f"{parts_a[i].name} / {parts_b[j].name}", "rows": len(rows)}
        for name, (chosen,) in groups.items():
            p = pose[chosen]
            x = _features(data["position_b"][p], rotation[p],
                          np.einsum("nij,j->ni", rotation[p], centre_b) - centre_a)
            y = np.c_[data["contact_depth"][chosen], data["contact_normal"][chosen],
                      data["contact_point"][chosen] - centre_a]
            order = np.random.default_rng(seed).permutation(len(chosen))
            cut = int(0.8 * len(chosen))
            got = _regress(x, y, order[:cut], order[cut:], hidden, epochs, seed)
            want = y[order[cut:]]
            normal = got[:, 1:4] / np.linalg.norm(got[:, 1:4], axis=1, keepdims=True)
            angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(normal, want[:, 1:4]), axis=1),
                                          np.einsum("ij,ij->i", normal, want[:, 1:4])))
            entry[name] = {
                "rows": len(chosen),
                "depth": float(np.quantile(np.abs(got[:, 0] - want[:, 0]), 0.99) / depth_tol),
                "normal": float(np.quantile(angle, 0.99) / scene.accuracy.normal_deg),
                "point": float(np.quantile(np.linalg.norm(got[:, 4:] - want[:, 4:], axis=1),
                                           0.99) / point_tol)}
        out.append(entry)
    return out


def expert_report(entries: list[dict]) -> str:
    """The expert figures as a markdown table (p99 error / tolerance: <= 1 meets it)."""
    lines = ["| part pair | experts on | rows | depth p99 / tol | normal p99 / tol | "
             "point p99 / tol |", "|---|---|---|---|---|---|"]
    for entry in entries:
        for name in ("part pair", "largest coarse region", "largest region"):
            f = entry[name]
            lines.append(f"| {entry['pair']} | {name} | {f['rows']} | {f['depth']:.2f} | "
                         f"{f['normal']:.2f} | {f['point']:.2f} |")
    return "\n".join(lines)


def report(figures: dict) -> str:
    """The figures as a markdown table."""
    lines = [f"rows: {figures['rows']} (held out: {1 - SPLIT[1]:.0%})", "",
             "| classifier | labels | exact set | " + " | ".join(
                 f"margin {m}: fallback / exact answered / missed" for m in MARGINS) + " |",
             "|---|---|---|" + "---|" * len(MARGINS)]
    for name, f in figures.items():
        if name == "rows":
            continue
        cells = [f"{f['margins'][m]['fallback']:.1%} / {f['margins'][m]['exact_answered']:.2%}"
                 f" / {f['margins'][m]['missed_rows']:.2%}" for m in MARGINS]
        lines.append(f"| {name} | {f['labels']} | {f['exact_set']:.1%} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def probe_arguments(description: str, rows: int) -> argparse.ArgumentParser:
    """The options every classifier probe takes: pair, rows (default ``rows``), data cache,
    width, epochs, seed."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--pair", default="container40/spreader", help="a/b of quay_crane_detail")
    parser.add_argument("--rows", type=int, default=rows, help="first-contact rows to label")
    parser.add_argument("--data", type=Path, help="npz cache of the labelled rows")
    parser.add_argument("--hidden", type=int, default=128, help="width of the hidden layers")
    parser.add_argument("--epochs", type=int, default=60, help="passes over the training rows")
    parser.add_argument("--seed", type=int, default=7)
    return parser


def main(argv=None) -> int:
    parser = probe_arguments(__doc__.split("\n")[0], 30000)
    parser.add_argument("--curve", action="store_true",
                        help="also the learning curve of corner fl's classifier")
    parser.add_argument("--experts", type=int, default=0,
                        help="also regress the contacts of this many most frequent part pairs")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    data = labelled_rows(args.pair, args.rows, args.seed, args.data)
    print(report(probe(data, args.pair, args.hidden, args.epochs, args.seed)))
    if args.curve:
        n = len(data["push"])
        sizes = [s for s in (2500, 5000, 10000, 20000, 40000, 80000) if s < SPLIT[0] * n]
        sizes.append(int(SPLIT[0] * n))
        print("\n| training rows | exact set | margin 0.02: fallback / exact answered |")
        print("|---|---|---|")
        for f in learning_curve(data, args.pair, sizes, args.hidden, args.seed):
            m = f["margins"][MARGINS[0]]
            print(f"| {f['train_rows']:,} | {f['exact_set']:.1%} | "
                  f"{m['fallback']:.1%} / {m['exact_answered']:.2%} |")
    if args.experts:
        print("\n" + expert_report(expert_figures(data, args.pair, args.experts, 64, 150,
                                                  args.seed)))
    print(f"\n{time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
