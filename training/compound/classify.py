"""Training of the group classifiers of a compound pair (issue #21, step 1).

For each group (:func:`impactnet.models.learned.compound.groups.part_groups`): the labels are
the group's part pairs seen touching in the training rows, and the region slots each label's
coarse regions seen there (:mod:`impactnet.models.learned.compound.regions`). A tanh MLP
(:class:`impactnet.training.fit.torch_mlp.StackedMLP`, one network) maps the group's features
to one logit per label and one per slot, trained by binary cross-entropy on the labels plus
the cross-entropy of a softmax over each touching label's slots (:func:`classifier_loss`),
with early stopping on validation rows. Then, on the validation rows:

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

from impactnet.models.bundle.compound_format import GROUP_INPUTS, LABEL_OUTPUTS
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
from impactnet.models.learned.compound.regions import N_REGION_CODES, mirror_regions
from impactnet.models.learned.mlp import MLP, MLPSpec
from impactnet.training.compound.rows import CompoundRows
from impactnet.training.fit.loop import FitConfig, GroupRows, fit
from impactnet.training.fit.torch_mlp import StackedMLP, input_statistics

#: Weight of the region term (cross-entropy per touching label) against the touch term
#: (binary cross-entropy per label) in the loss; both are in nats.
REGION_WEIGHT = 1.0
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


def classifier_loss(v: int, slot_label: np.ndarray):
    """The loss of a classifier with ``v`` labels and region slots of labels ``slot_label``
    (r,): (G, B) binary cross-entropy of the v label logits, averaged over the labels, plus
    :data:`REGION_WEIGHT` times the cross-entropy of each touching label's true slot under a
    softmax over that label's slots, averaged over the row's touching labels."""
    member = torch.as_tensor(slot_label[None, :] == np.arange(v)[:, None])  # (v, r)
    outside = torch.where(member, 0.0, -torch.inf)
    owner = torch.as_tensor(slot_label, dtype=torch.long)

    def loss(model: StackedMLP, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        logits = model(x)
        touch = torch.nn.functional.binary_cross_entropy_with_logits(
            logits[..., :v], y[..., :v], reduction="none").mean(dim=2)
        slots = logits[..., v:]
        per_label = torch.logsumexp(slots[..., None, :] + outside, dim=-1)  # (G, B, v)
        log_p = slots - per_label[..., owner]
        region = -(y[..., v:] * log_p).sum(dim=2) / y[..., :v].sum(dim=2).clamp(min=1.0)
        return touch + REGION_WEIGHT * region
    return loss


def _keys(pairs: np.ndarray) -> np.ndarray:
    return pairs[:, 0] * 65536 + pairs[:, 1]


def region_slots(labels: np.ndarray, keys: np.ndarray, codes: np.ndarray, pose: np.ndarray,
                 train: np.ndarray) -> np.ndarray:
    """(r, 2) int64 (label index, region code) of the contacts of training poses ``train``
    whose part pair (``keys`` (c, 2), at ``pose`` (c,), regions ``codes`` (c,)) is one of
    ``labels`` (v, 2), sorted by label then code."""
    known = np.isin(_keys(keys), _keys(labels)) & np.isin(pose, train)
    label = np.searchsorted(_keys(labels), _keys(keys[known]))
    return np.unique(np.c_[label, codes[known]], axis=0).reshape(-1, 2).astype(np.int64)


def label_matrix(n: int, labels: np.ndarray, slots: np.ndarray, pose: np.ndarray,
                 keys: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """(n, v + r) float32: 1 where row ``pose[c]`` touches the label ``keys[c]`` ((c, 2) part
    pairs), for every contact c whose part pair is one of ``labels`` (v, 2); then 1 at the
    slot of ``slots`` (r, 2) of its label and region ``codes[c]``, where training saw it."""
    v = len(labels)
    y = np.zeros((n, v + len(slots)), np.float32)
    known = np.flatnonzero(np.isin(_keys(keys), _keys(labels)))
    label = np.searchsorted(_keys(labels), _keys(keys[known]))
    y[pose[known], label] = 1.0
    slot_key = slots[:, 0] * N_REGION_CODES + slots[:, 1]
    key = label * N_REGION_CODES + codes[known]
    seen = np.isin(key, slot_key)
    y[pose[known][seen], v + np.searchsorted(slot_key, key[seen])] = 1.0
    return y


def region_accuracy(region_logits: np.ndarray, y: np.ndarray, slot_label: np.ndarray) -> float:
    """Share of the touching labels of rows ``y`` (m, v + r) whose slot of largest logit
    (``region_logits`` (m, r), among the label's slots) is their true region."""
    v = y.shape[1] - len(slot_label)
    rows, label = np.nonzero(y[:, :v] > 0.5)
    if not len(rows):
        return 1.0
    masked = np.where(slot_label[None, :] == label[:, None], region_logits[rows], -np.inf)
    return float((y[rows, v + np.argmax(masked, axis=1)] > 0.5).mean())


def fit_calibrated(x, y, slots, train, val, config: ClassifierConfig, name: str, seed: int,
                   desc: str) -> tuple[MLP, dict, dict, dict]:
    """(MLP, its tensors, its spec entry, figures): one tanh network fitted to the labels and
    region slots ``y`` (n, v + r) (:func:`label_matrix`, ``slots`` (r, 2)) of features ``x``
    (n, 9) on rows ``train``, early-stopped and calibrated (temperature, candidate floor) on
    rows ``val``."""
    v = y.shape[1] - len(slots)
    spec = MLPSpec("tanh", (x.shape[1], *config.hidden, y.shape[1]), GROUP_INPUTS,
                   LABEL_OUTPUTS)
    generator = torch.Generator().manual_seed(seed)
    model = StackedMLP(spec, 1, generator)
    model.set_normalisation(*input_statistics(x[train]))
    record = fit(model, classifier_loss(v, slots[:, 0]), torch.as_tensor(x, dtype=torch.float32),
                 torch.as_tensor(y), GroupRows([train]), GroupRows([val]), config.fit,
                 generator, desc=desc, progress=False)
    tensors = model.export(0, name)
    mlp = MLP.from_tensors(name, tensors, spec)
    logits = mlp.forward(x[val].astype(np.float32))
    temperature, candidate_min = calibrate(logits[:, :v], y[val, :v])
    figures = {"labels": v, "region_slots": len(slots), "epochs": record.epochs_run,
               "seconds": round(record.seconds, 1), "temperature": temperature,
               "candidate_min": candidate_min,
               "region_accuracy_validation": region_accuracy(logits[:, v:], y[val], slots[:, 0])}
    return mlp, tensors, {name: spec.to_dict()}, figures


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
    keys = np.c_[rows.part_a[members], rows.part_b[members]]
    pose, codes = rows.pose[members], rows.region[members]
    labels = np.unique(keys[np.isin(pose, rows.train)], axis=0).reshape(-1, 2)
    lo, hi = widened_domain(x[rows.train])
    slots = region_slots(labels, keys, codes, pose, rows.train)
    if len(labels) == 0:
        return (GroupClassifier(group, labels, slots[:, 0], slots[:, 1], None, 1.0, 0.5, lo, hi),
                {}, {}, {"labels": 0})
    y = label_matrix(len(rows), labels, slots, pose, keys, codes)
    mlp, tensors, specs, figures = fit_calibrated(x, y, slots, rows.train, rows.val, config,
                                                  name, seed, f"classifier {group.name}")
    return (GroupClassifier(group, labels, slots[:, 0], slots[:, 1], mlp, figures["temperature"],
                            figures["candidate_min"], lo, hi), tensors, specs, figures)


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
    xs, keys, poses, codes = [], [], [], []
    for g, (mirror, map_a, map_b) in enumerate(maps):
        xs.append(mirror_features(group_features(groups[g], rows.position, rows.rotation),
                                  mirror))
        members = np.flatnonzero(owner == g)
        keys.append(np.c_[map_a[rows.part_a[members]], map_b[rows.part_b[members]]])
        poses.append(rows.pose[members] + g * n)
        codes.append(mirror_regions(rows.region[members], mirror))
    pose, keys, codes = np.concatenate(poses), np.concatenate(keys), np.concatenate(codes)
    shift = np.arange(k)[:, None] * n  # corner g's pose i is row g * n + i
    train, val = (rows.train + shift).ravel(), (rows.val + shift).ravel()
    x = np.concatenate(xs)
    labels = np.unique(keys[np.isin(pose, train)], axis=0).reshape(-1, 2)
    slots = region_slots(labels, keys, codes, pose, train)
    y = label_matrix(k * n, labels, slots, pose, keys, codes)
    mlp, tensors, specs, figures = fit_calibrated(x, y, slots, train, val, config, name, seed,
                                                  "pooled classifier")
    lo, hi = widened_domain(x[train])
    classifiers = [GroupClassifier(groups[g], np.c_[map_a[labels[:, 0]], map_b[labels[:, 1]]],
                                   slots[:, 0], slots[:, 1], mlp, figures["temperature"],
                                   figures["candidate_min"], lo, hi, tuple(mirror))
                   for g, (mirror, map_a, map_b) in enumerate(maps)]
    return classifiers, tensors, specs, figures | {"pooled_corners": k}


def group_entry(clf: GroupClassifier, name: str | None) -> dict:
    """A classifier's manifest entry (``groups[k]``, impactnet.models.bundle.compound_format)."""
    g = clf.group
    return {"name": g.name, "parts_a": list(g.parts_a), "parts_b": list(g.parts_b),
            "centre_a": list(g.centre_a), "centre_b": list(g.centre_b),
            "labels": clf.labels.tolist(),
            "regions": np.c_[clf.region_label, clf.region_codes].astype(int).tolist(),
            "classifier": name if clf.mlp is not None else None,
            "temperature": clf.temperature, "candidate_min": clf.candidate_min,
            "domain_lo": clf.domain_lo.tolist(), "domain_hi": clf.domain_hi.tolist(),
            "mirror": list(clf.mirror)}
