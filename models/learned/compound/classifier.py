"""The served classifier of one part group: which of its part pairs touch, and in which coarse
region (issue #21, step 1).

An MLP (:mod:`impactnet.models.learned.mlp`, trained by :mod:`impactnet.training.compound.classify`)
maps the group's features (:func:`impactnet.models.learned.compound.groups.group_features`) to one
logit per label, a part pair seen touching in training, then one logit per *region slot*: a (label,
coarse region) pair seen in training (:mod:`impactnet.models.learned.compound.regions`).
Probabilities are ``sigmoid(logit / temperature)``, the temperature calibrated on validation rows; a
touching label's region is the slot of largest logit among its own (a softmax per label). A label
with a probability of at least ``candidate_min`` (calibrated so that no validation row misses a
touching pair) is a candidate, which its region's expert then answers. A row whose features lie
outside the box of the training rows (widened by :data:`DOMAIN_MARGIN_REL`) is *unsure*: the chain
sends it to the oracle.

A classifier may be shared by the four corners of symmetric bodies: each corner's group then
sees its features through its mirror (``mirror``,
:func:`impactnet.models.learned.compound.groups.mirror_features`) and names its own part pairs (the
shared labels mapped through the mirror), so one network learns from four times the rows. Its
regions are named in corner fl's frame and mapped back through the mirror.

The whole stage (features, MLP, probabilities, regions, domain) is one compiled row function
(:mod:`impactnet.models.learned.compound.kernel_classify`), run for one classifier by
:meth:`GroupClassifier.classify` and for all the classifiers of a pair at once by the chain.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from impactnet.models.compiled import PARALLEL_MIN_ROWS
from impactnet.models.learned.compound.groups import N_GROUP_FEATURES, PartGroup
from impactnet.models.learned.compound.kernel_classify import (
    LOGIT_CLIP,
    Classified,
    ClassifierSet,
    classifier_set,
    classify,
)
from impactnet.models.learned.mlp import MLP, MLPSpec

#: The training rows' range of each feature is widened by this share of its width on each
#: side: a pose a little past the drawn families is still answered, one far past is not.
DOMAIN_MARGIN_REL = 0.02


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

    @cached_property
    def compiled(self) -> ClassifierSet:
        """This classifier alone as the kernel takes it."""
        return classifier_set([self])

    def classify(self, position, rotation) -> Classified:
        """Its labels' probabilities, regions (in the group's own frame) and shares, and whether
        each pose lies in the domain
        (:func:`impactnet.models.learned.compound.kernel_classify.classify`).

        Parameters
        ----------
        position : ndarray, shape (n, 3)
            B's origin in A's frame (m).
        rotation : ndarray, shape (n, 3, 3)
            B's orientation in A's frame.
        """
        return classify(self.compiled, position, rotation)


def sigmoid_probabilities(logits: np.ndarray, temperature: float) -> np.ndarray:
    """``sigmoid(logits / temperature)``, clipped as the kernel serves it, for training's
    calibration (on logits from :meth:`impactnet.models.learned.mlp.MLP.forward`)."""
    z = np.clip(np.asarray(logits, np.float64) / temperature, -LOGIT_CLIP, LOGIT_CLIP)
    return 1.0 / (1.0 + np.exp(-z))


def widened_domain(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo (9,), hi (9,)) of training features ``x`` (n, 9), widened by
    :data:`DOMAIN_MARGIN_REL` of each feature's width."""
    lo, hi = x.min(axis=0), x.max(axis=0)
    pad = DOMAIN_MARGIN_REL * (hi - lo)
    return lo - pad, hi + pad


def warm_up() -> None:
    """Compile (or load) the classifier kernels
    (:mod:`impactnet.models.learned.compound.kernel_classify`) for the argument types
    :meth:`GroupClassifier.classify` and the chain pass: one pose, and serial and parallel
    batches (a tiny two-classifier set, zero weights)."""
    spec = MLPSpec("tanh", (N_GROUP_FEATURES, 2, 3), "group-pose-v1", "part-labels-regions-v1")
    mlp = MLP(spec, [np.zeros((2, N_GROUP_FEATURES)), np.zeros((3, 2))],
              [np.zeros(2), np.zeros(3)], np.zeros(N_GROUP_FEATURES),
              np.ones(N_GROUP_FEATURES), np.zeros(3), np.ones(3))
    group = PartGroup("body", (), (), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    one = GroupClassifier(group, np.zeros((1, 2), np.int64), np.zeros(2, np.int64),
                          np.array([36, 37]), mlp, 1.0, 0.5, np.full(N_GROUP_FEATURES, -1.0),
                          np.full(N_GROUP_FEATURES, 1.0))
    classifiers = classifier_set([one, one])
    for n in (1, PARALLEL_MIN_ROWS):
        classify(classifiers, np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)))
