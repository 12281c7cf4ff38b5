"""The served classifier of one part group: which of its part pairs touch, and in which coarse
region (issue #21, step 1).

An MLP (:mod:`impactnet.models.learned.mlp`, trained by
:mod:`impactnet.training.compound.classify`) maps the group's features
(:func:`impactnet.models.learned.compound.groups.group_features`) to one logit per label, a part
pair seen touching in training, then one logit per *region slot*: a (label, coarse region) pair
seen in training (:mod:`impactnet.models.learned.compound.regions`). Probabilities are
``sigmoid(logit / temperature)``, the temperature calibrated on validation rows; a touching
label's region is the slot of largest logit among its own (a softmax per label). A label with
a probability of at least ``candidate_min`` (calibrated so that no validation row misses a
touching pair) is a candidate, which its region's expert then answers. A row whose features lie
outside the box of the training rows (widened by :data:`DOMAIN_MARGIN_REL`) is *unsure*: the
chain sends it to the oracle.

A classifier may be shared by the four corners of symmetric bodies: each corner's group then
sees its features through its mirror (``mirror``, :func:`impactnet.models.learned.compound.
groups.mirror_features`) and names its own part pairs (the shared labels mapped through the
mirror), so one network learns from four times the rows. Its regions are named in corner fl's
frame and mapped back through the mirror.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from impactnet.models.learned.compound.groups import PartGroup, group_features, mirror_features
from impactnet.models.learned.compound.regions import mirror_regions
from impactnet.models.learned.mlp import MLP

#: The training rows' range of each feature is widened by this share of its width on each
#: side: a pose a little past the drawn families is still answered, one far past is not.
DOMAIN_MARGIN_REL = 0.02
#: Logits are clipped to +-this before the sigmoid (float64 exp stays finite).
LOGIT_CLIP = 60.0


@dataclass(frozen=True)
class GroupClassifier:
    """One group's classifier with its calibration."""

    group: PartGroup  # the parts it covers and its feature centres
    labels: np.ndarray  # (v, 2) int: (A's part, B's part) of each label
    region_label: np.ndarray  # (r,) int: the label of each region slot, ascending
    region_codes: np.ndarray  # (r,) int: the coarse region of each slot, in the frame the
    # features are seen in (through ``mirror``)
    mlp: MLP | None  # features (9) -> v + r logits; None when the group has no label
    temperature: float  # calibrated: p = sigmoid(logit / temperature), > 0
    candidate_min: float  # a label with p >= this is a candidate, in (0, 1)
    domain_lo: np.ndarray  # (9,) training rows' feature minimum, widened
    domain_hi: np.ndarray  # (9,) training rows' feature maximum, widened
    mirror: tuple[float, float, float] = (1.0, 1.0, 1.0)  # the features are seen through this
    # mirror (a corner pooled with the others in corner fl's frame; identity: its own frame)

    def probabilities(self, position, rotation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(probabilities (n, v) float64, region logits (n, r) float32, inside (n,) bool: the
        row lies in the domain).

        Parameters
        ----------
        position : ndarray, shape (n, 3)
            B's origin in A's frame (m).
        rotation : ndarray, shape (n, 3, 3)
            B's orientation in A's frame.
        """
        x = mirror_features(group_features(self.group, position, rotation), self.mirror)
        inside = ((x >= self.domain_lo) & (x <= self.domain_hi)).all(axis=1)
        if self.mlp is None:
            return np.zeros((len(x), 0)), np.zeros((len(x), 0), np.float32), inside
        logits = self.mlp.forward(x.astype(np.float32))
        v = len(self.labels)
        return sigmoid_probabilities(logits[:, :v], self.temperature), logits[:, v:], inside

    @cached_property
    def slot_table(self) -> np.ndarray:
        """(v, s) int: each label's region slots, padded with -1 (s: the most of any label)."""
        v = len(self.labels)
        counts = np.bincount(self.region_label, minlength=v)
        table = np.full((v, max(int(counts.max(initial=0)), 1)), -1, np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        slot = np.arange(len(self.region_label))
        table[self.region_label, slot - starts[self.region_label]] = slot
        return table

    def regions(self, region_logits: np.ndarray, pose: np.ndarray, label: np.ndarray):
        """(codes (k,) int64, probability (k,)): the coarse region of candidates ``(pose,
        label)`` (k,) each, the slot of largest logit among the label's, in the group's own
        frame (mapped back through the mirror), and its softmax probability among them."""
        if not len(pose):  # no candidate (or no label at all)
            return np.zeros(0, np.int64), np.zeros(0)
        slots = self.slot_table[label]  # (k, s)
        logits = np.where(slots >= 0, region_logits[pose[:, None], np.maximum(slots, 0)],
                          -np.inf).astype(np.float64)
        best = np.argmax(logits, axis=1)
        top = logits[np.arange(len(best)), best]
        share = 1.0 / np.sum(np.exp(logits - top[:, None]), axis=1)
        return mirror_regions(self.region_codes[slots[np.arange(len(best)), best]],
                              self.mirror), share


def sigmoid_probabilities(logits: np.ndarray, temperature: float) -> np.ndarray:
    """``sigmoid(logits / temperature)``, clipped as served (training's calibration uses it)."""
    z = np.clip(np.asarray(logits, np.float64) / temperature, -LOGIT_CLIP, LOGIT_CLIP)
    return 1.0 / (1.0 + np.exp(-z))


def widened_domain(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo (9,), hi (9,)) of training features ``x`` (n, 9), widened by
    :data:`DOMAIN_MARGIN_REL` of each feature's width."""
    lo, hi = x.min(axis=0), x.max(axis=0)
    pad = DOMAIN_MARGIN_REL * (hi - lo)
    return lo - pad, hi + pad
