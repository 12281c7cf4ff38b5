"""A compound pair's classifiers, compiled: for each pose, every group's features, its MLP, the
labels' probabilities, each label's coarse region and whether the pose lies in the domain; one
row function for one pose and for a batch (:mod:`impactnet.models.compiled`).

The classifiers of a pair
(:class:`~impactnet.models.learned.compound.classifier.GroupClassifier`, one per group) are gathered
into one :class:`ClassifierSet`: their MLPs as one pack (:func:`impactnet.models.learned.mlp.pack`),
their labels numbered one after another (classifier order, then label order) and these arrays:

* ``table`` (C, 4) int64: per classifier, its member in the pack (-1: no label), its first
  label, its number of labels v and its first slot;
* ``frames`` (C, 28) float64: per classifier, A's group centre, B's group centre, the mirror
  (3 each), the temperature, the domain's low and high ends (9 each);
* ``slots`` (V, 2) int64: per label, its first region slot (among its classifier's slots) and
  how many it has; ``codes`` (S,) int64: the coarse region of each slot, mapped back through
  the mirror (its group's own frame).

Per pose and classifier (:func:`classify_row`): the features (B's group centre in A's group
frame and B's rotation's first two columns, seen through the mirror:
:func:`impactnet.models.learned.compound.groups.group_features`, ``mirror_features``), the domain
test, the MLP (:func:`impactnet.models.learned.kernel_mlp.forward`: one logit per label, then one
per slot), ``sigmoid(clip(logit / temperature, +-60))`` per label and the slot of largest logit
among the label's own (the first where several tie) with its softmax share. A label is a candidate
where its probability reaches its classifier's ``candidate_min`` (the caller's mask).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from impactnet.models.compiled import jit, numba, parallel_jit
from impactnet.models.learned.compound.groups import N_GROUP_FEATURES
from impactnet.models.learned.compound.regions import mirror_regions
from impactnet.models.learned.kernel_mlp import TILE_ROWS, forward, run_rows, widest
from impactnet.models.learned.mlp import frozen, pack

#: Logits are clipped to +-this before the sigmoid (float64 exp stays finite).
LOGIT_CLIP = 60.0
#: Columns of ``frames``.
CENTRE_A, CENTRE_B, MIRROR, TEMPERATURE, LOW, HIGH = 0, 3, 6, 9, 10, 19
N_FRAME = 28


class Classified(NamedTuple):
    """The classifiers' answer for n poses (V labels, in the set's order)."""

    probability: np.ndarray  # (n, V) float64, sigmoid(logit / temperature)
    region: np.ndarray  # (n, V) int64, the label's best slot's coarse region (-1: no slot)
    share: np.ndarray  # (n, V) float64, that slot's softmax share among the label's slots
    inside: np.ndarray  # (n,) bool, the pose lies in every classifier's domain


class ClassifierSet(NamedTuple):
    """Classifiers as the kernel takes them (module docstring)."""

    weights: np.ndarray
    layers: np.ndarray
    members: np.ndarray
    table: np.ndarray
    frames: np.ndarray
    slots: np.ndarray
    codes: np.ndarray


def classifier_set(classifiers) -> ClassifierSet:
    """The :class:`ClassifierSet` of a sequence of GroupClassifiers (read-only arrays)."""
    table, frames, slots, codes, mlps = [], [], [], [], []
    label = slot = 0
    for clf in classifiers:
        v = len(clf.labels)
        table.append((len(mlps) if clf.mlp is not None else -1, label, v, slot))
        if clf.mlp is not None:
            mlps.append(clf.mlp)
        frames.append(np.concatenate([clf.group.centre_a, clf.group.centre_b, clf.mirror,
                                      [clf.temperature], clf.domain_lo, clf.domain_hi]))
        counts = np.bincount(np.asarray(clf.region_label, np.int64), minlength=v)
        slots.append(np.column_stack([np.cumsum(counts) - counts, counts]))
        codes.append(mirror_regions(np.asarray(clf.region_codes, np.int64), clf.mirror))
        label, slot = label + v, slot + len(clf.region_codes)
    arrays = (np.array(table, np.int64).reshape(-1, 4),
              np.array(frames, np.float64).reshape(-1, N_FRAME),
              np.concatenate(slots).astype(np.int64) if slots else np.zeros((0, 2), np.int64),
              np.concatenate(codes).astype(np.int64) if codes else np.zeros(0, np.int64))
    return ClassifierSet(*pack(mlps), *(frozen(np.ascontiguousarray(a)) for a in arrays))


@jit
def _features(frame, position, rotation, row, h):
    """The group features of pose ``row`` seen through the mirror into ``h[:9]``; whether they
    lie in the domain."""
    for i in range(3):
        at = position[row, i] + (rotation[row, i, 0] * frame[CENTRE_B]
                                 + rotation[row, i, 1] * frame[CENTRE_B + 1]
                                 + rotation[row, i, 2] * frame[CENTRE_B + 2])
        m = frame[MIRROR + i]
        h[i] = (at - frame[CENTRE_A + i]) * m
        h[3 + i] = rotation[row, i, 0] * m * frame[MIRROR]
        h[6 + i] = rotation[row, i, 1] * m * frame[MIRROR + 1]
    inside = True
    for f in range(N_GROUP_FEATURES):
        inside = inside and frame[LOW + f] <= h[f] <= frame[HIGH + f]
    return inside


@jit
def _labels(h, at, v, temperature, slots, codes, first_label, first_slot, row, out):
    """Each label's probability, best region and share from the logits at ``h[at:]``."""
    probability, region, share = out
    for label in range(v):
        z = min(max(h[at + label] / temperature, -LOGIT_CLIP), LOGIT_CLIP)
        probability[row, first_label + label] = 1.0 / (1.0 + math.exp(-z))
        start, count = slots[first_label + label, 0], slots[first_label + label, 1]
        best, top = -1, -np.inf
        for k in range(count):
            logit = h[at + v + start + k]
            if best < 0 or logit > top:
                best, top = k, logit
        total = 0.0
        for k in range(count):
            total += math.exp(h[at + v + start + k] - top)
        region[row, first_label + label] = codes[first_slot + start + best] if best >= 0 else -1
        share[row, first_label + label] = 1.0 / total if best >= 0 else 0.0


@jit
def classify_row(weights, layers, members, table, frames, slots, codes, position, rotation,
                 row, h, width, out, inside):
    """Every classifier of the set on pose ``row`` (B's position (n, 3) and rotation (n, 3, 3)
    in A's frame) into row ``row`` of ``out`` (probability, region, share) and ``inside``."""
    inside[row] = True
    for c in range(table.shape[0]):
        inside[row] = _features(frames[c], position, rotation, row, h) and inside[row]
        if table[c, 0] >= 0:
            at = forward(weights, layers, members, table[c, 0], h, width)
            _labels(h, at, table[c, 2], frames[c, TEMPERATURE], slots, codes, table[c, 1],
                    table[c, 3], row, out)


@jit
def classify_rows(weights, layers, members, table, frames, slots, codes, position, rotation,
                  out, inside, start, stop):
    """Poses ``start:stop``, serially (:func:`classify_row`)."""
    width = max(widest(layers), N_GROUP_FEATURES)
    h = np.empty(3 * width)
    for row in range(start, stop):
        classify_row(weights, layers, members, table, frames, slots, codes, position, rotation,
                     row, h, width, out, inside)


@parallel_jit
def classify_rows_parallel(weights, layers, members, table, frames, slots, codes, position,
                           rotation, out, inside, start, stop):
    """:func:`classify_rows` over the kernel threads, a tile of poses at a time."""
    width = max(widest(layers), N_GROUP_FEATURES)
    tiles = (stop - start + TILE_ROWS - 1) // TILE_ROWS
    for tile in numba.prange(tiles):
        h = np.empty(3 * width)
        for row in range(start + tile * TILE_ROWS, min(stop, start + (tile + 1) * TILE_ROWS)):
            classify_row(weights, layers, members, table, frames, slots, codes, position,
                         rotation, row, h, width, out, inside)


def classify(classifiers: ClassifierSet, position, rotation) -> Classified:
    """The classifiers' answer (:class:`Classified`) for B's poses in A's frame: ``position``
    (n, 3) metres and ``rotation`` (n, 3, 3)."""
    position = np.ascontiguousarray(position, np.float64)
    rotation = np.ascontiguousarray(rotation, np.float64)
    n, labels = len(position), len(classifiers.slots)
    out = (np.empty((n, labels)), np.empty((n, labels), np.int64), np.empty((n, labels)))
    inside = np.empty(n, np.bool_)
    run_rows(classify_rows, classify_rows_parallel, n, *classifiers, position, rotation, out,
             inside)
    return Classified(*out, inside)
