"""Training of the group classifiers of a compound pair (issue #21, step 1).

For each group (:func:`impactnet.models.learned.compound.groups.part_groups`): the labels are
the group's part pairs seen touching in the training rows; a tanh MLP
(:class:`impactnet.training.fit.torch_mlp.StackedMLP`, one network) maps the group's features
to one logit per label, trained by binary cross-entropy with early stopping on validation rows.
Then, on the validation rows:

* the temperature of the sigmoid is the one of :data:`TEMPERATURES` with the least
  cross-entropy (calibration);
* ``candidate_min`` is :data:`CANDIDATE_SAFETY` times the smallest probability that a touching
  validation label gets, within [:data:`CANDIDATE_FLOOR`, 0.5]: no validation row misses a
  touching part pair that the vocabulary holds.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from impactnet.models.learned.compound.classifier import (
    GroupClassifier,
    sigmoid_probabilities,
    widened_domain,
)
from impactnet.models.learned.compound.groups import (
    CORNER_MIRRORS,
    group_features,
    group_of_pairs,
    mirror_features,
    mirror_map,
)
from impactnet.models.learned.mlp import MLP, MLPSpec
from impactnet.training.compound.rows import CompoundRows
from impactnet.training.fit.loop import FitConfig, GroupRows, fit
from impactnet.training.fit.torch_mlp import StackedMLP, input_statistics

GROUP_INPUTS, LABEL_OUTPUTS = "group-pose-v1", "part-labels-v1"
#: Temperatures tried by the calibration (dimensionless, geometric grid around 1).
TEMPERATURES = np.geomspace(0.25, 4.0, 33)
#: ``candidate_min`` is this share of the smallest probability of a touching validation label:
#: a margin for held-out rows less sure than the least sure of a few thousand validation rows
#: (on the spreader's held-out rows, 0.5 missed a touching pair on 6 of 2,400 rows and 0.05 on
#: none, at 3.4 and 4.6 candidates per pose).
CANDIDATE_SAFETY = 0.1
#: Smallest ``candidate_min`` (a probability): below, the classifier names nearly every label.
CANDIDATE_FLOOR = 1e-6


@dataclass(frozen=True)
class ClassifierConfig:
    """The group classifiers of a compound pair."""

    hidden: tuple[int, ...] = (128, 128, 128)  # hidden widths of each group's MLP
    pooled: bool = True  # one classifier for the four corners, each seen through its mirror
    # (train_pooled), where both bodies are mirror-symmetric; off: one per corner
    fit: FitConfig = field(default_factory=lambda: FitConfig(
        batch_size=256, steps_per_epoch=200, max_epochs=120, patience=12, val_rows=8192))


def _bce(model: StackedMLP, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """(G, B) binary cross-entropy of the logits, averaged over the labels."""
    logits = model(x)
    return torch.nn.functional.binary_cross_entropy_with_logits(
        logits, y, reduction="none").mean(dim=2)


def label_matrix(rows: CompoundRows, labels: np.ndarray, members: np.ndarray) -> np.ndarray:
    """(n, v) float32: 1 where pose n touches label v (``members``: the contacts of the
    group)."""
    y = np.zeros((len(rows), len(labels)), np.float32)
    key = rows.part_a[members] * 65536 + rows.part_b[members]
    vocab = labels[:, 0] * 65536 + labels[:, 1]
    known = np.isin(key, vocab)
    y[rows.pose[members][known], np.searchsorted(vocab, key[known])] = 1.0
    return y


def calibrate(logits: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(temperature, candidate_min) from validation logits (m, v) and labels (m, v)."""
    losses = []
    for t in TEMPERATURES:
        p = np.clip(sigmoid_probabilities(logits, t), 1e-12, 1 - 1e-12)
        losses.append(-np.mean(y * np.log(p) + (1 - y) * np.log(1 - p)))
    temperature = float(TEMPERATURES[int(np.argmin(losses))])
    p = sigmoid_probabilities(logits, temperature)
    least = float(p[y > 0.5].min()) if (y > 0.5).any() else 0.5
    return temperature, float(np.clip(CANDIDATE_SAFETY * least, CANDIDATE_FLOOR, 0.5))


def train_group(rows: CompoundRows, groups, g: int, config: ClassifierConfig, name: str,
                seed: int) -> tuple[GroupClassifier, dict, dict, dict]:
    """(classifier, tensors, MLP specs, figures) of group ``g``."""
    group = groups[g]
    x = group_features(group, rows.position, rows.rotation)
    members = np.flatnonzero(group_of_pairs(groups, rows.part_a, rows.part_b) == g)
    in_train = np.isin(rows.pose[members], rows.train)
    labels = np.unique(np.c_[rows.part_a[members], rows.part_b[members]][in_train], axis=0)
    labels = labels.reshape(-1, 2)
    lo, hi = widened_domain(x[rows.train])
    if len(labels) == 0:
        return GroupClassifier(group, labels, None, 1.0, 0.5, lo, hi), {}, {}, {"labels": 0}
    y = label_matrix(rows, labels, members)
    spec = MLPSpec("tanh", (x.shape[1], *config.hidden, len(labels)), GROUP_INPUTS,
                   LABEL_OUTPUTS)
    generator = torch.Generator().manual_seed(seed)
    model = StackedMLP(spec, 1, generator)
    model.set_normalisation(*input_statistics(x[rows.train]))
    record = fit(model, _bce, torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(y),
                 GroupRows([rows.train]), GroupRows([rows.val]), config.fit, generator,
                 desc=f"classifier {group.name}", progress=False)
    tensors = model.export(0, name)
    mlp = MLP.from_tensors(name, tensors, spec)
    logits = mlp.forward(x[rows.val].astype(np.float32))
    temperature, candidate_min = calibrate(logits, y[rows.val])
    figures = {"labels": len(labels), "epochs": record.epochs_run,
               "seconds": round(record.seconds, 1), "temperature": temperature,
               "candidate_min": candidate_min}
    return (GroupClassifier(group, labels, mlp, temperature, candidate_min, lo, hi), tensors,
            {name: spec.to_dict()}, figures)


def pooled_maps(parts_a, parts_b, groups) -> list | None:
    """Per corner group, (mirror, A's part map, B's part map) onto corner fl; None where the
    groups are not the four corners or a body is not mirror-symmetric."""
    if [g.name for g in groups[:-1]] != list(CORNER_MIRRORS):
        return None
    maps = [(CORNER_MIRRORS[g.name], mirror_map(parts_a, CORNER_MIRRORS[g.name]),
             mirror_map(parts_b, CORNER_MIRRORS[g.name])) for g in groups[:-1]]
    return None if any(m[1] is None or m[2] is None for m in maps) else maps


def train_pooled(rows: CompoundRows, groups, maps, config: ClassifierConfig, name: str,
                 seed: int) -> tuple[list[GroupClassifier], dict, dict, dict]:
    """(one classifier per corner group sharing one MLP, tensors, specs, figures): the four
    corners' rows seen in corner fl's frame (``maps`` from :func:`pooled_maps`), their part
    pairs mapped onto fl's, one network trained on all of them and calibrated on all their
    validation rows."""
    n, k = len(rows), len(maps)
    owner = group_of_pairs(groups, rows.part_a, rows.part_b)
    xs, keys, poses = [], [], []
    for g, (mirror, map_a, map_b) in enumerate(maps):
        xs.append(mirror_features(group_features(groups[g], rows.position, rows.rotation),
                                  mirror))
        members = np.flatnonzero(owner == g)
        keys.append(np.c_[map_a[rows.part_a[members]], map_b[rows.part_b[members]]])
        poses.append(rows.pose[members] + g * n)
    stacked = _stacked_rows(rows, k, np.concatenate(poses), np.concatenate(keys))
    x = np.concatenate(xs)
    labels = np.unique(stacked.keys[np.isin(stacked.pose, stacked.train)], axis=0).reshape(-1, 2)
    y = np.zeros((k * n, len(labels)), np.float32)
    vocab = labels[:, 0] * 65536 + labels[:, 1]
    key = stacked.keys[:, 0] * 65536 + stacked.keys[:, 1]
    known = np.isin(key, vocab)
    y[stacked.pose[known], np.searchsorted(vocab, key[known])] = 1.0
    spec = MLPSpec("tanh", (x.shape[1], *config.hidden, len(labels)), GROUP_INPUTS,
                   LABEL_OUTPUTS)
    generator = torch.Generator().manual_seed(seed)
    model = StackedMLP(spec, 1, generator)
    model.set_normalisation(*input_statistics(x[stacked.train]))
    record = fit(model, _bce, torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(y),
                 GroupRows([stacked.train]), GroupRows([stacked.val]), config.fit, generator,
                 desc="pooled classifier", progress=False)
    tensors = model.export(0, name)
    mlp = MLP.from_tensors(name, tensors, spec)
    temperature, candidate_min = calibrate(mlp.forward(x[stacked.val].astype(np.float32)),
                                           y[stacked.val])
    lo, hi = widened_domain(x[stacked.train])
    classifiers = [GroupClassifier(groups[g], np.c_[map_a[labels[:, 0]], map_b[labels[:, 1]]],
                                   mlp, temperature, candidate_min, lo, hi, tuple(mirror))
                   for g, (mirror, map_a, map_b) in enumerate(maps)]
    figures = {"labels": len(labels), "pooled_corners": k, "epochs": record.epochs_run,
               "seconds": round(record.seconds, 1), "temperature": temperature,
               "candidate_min": candidate_min}
    return classifiers, tensors, {name: spec.to_dict()}, figures


class _Stacked:
    """Rows of k corners stacked: corner g's pose i is row g * n + i."""

    def __init__(self, pose, keys, train, val):
        self.pose, self.keys, self.train, self.val = pose, keys, train, val


def _stacked_rows(rows: CompoundRows, k: int, pose, keys) -> _Stacked:
    shift = (np.arange(k)[:, None] * len(rows))
    return _Stacked(pose, keys, (rows.train[None, :] + shift).ravel(),
                    (rows.val[None, :] + shift).ravel())


def group_entry(clf: GroupClassifier, name: str | None) -> dict:
    """A classifier's manifest entry (``groups[k]``, impactnet.models.bundle.compound_format)."""
    g = clf.group
    return {"name": g.name, "parts_a": list(g.parts_a), "parts_b": list(g.parts_b),
            "centre_a": list(g.centre_a), "centre_b": list(g.centre_b),
            "labels": clf.labels.tolist(), "classifier": name if clf.mlp is not None else None,
            "temperature": clf.temperature, "candidate_min": clf.candidate_min,
            "domain_lo": clf.domain_lo.tolist(), "domain_hi": clf.domain_hi.tolist(),
            "mirror": list(clf.mirror)}
