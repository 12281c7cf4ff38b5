"""The warm-up compiles every kernel of the learned runtime: after it, the predictors (every
mode, one pair, serial and parallel batches, swapped rows, a bundle of other widths and
committee sizes), the MLPs, the labeller and the compound classifiers compile nothing new; and
the one-pair entry is closed to other argument types."""
from __future__ import annotations

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from impactnet import models
from impactnet.models.compiled import PARALLEL_MIN_ROWS
from impactnet.models.learned import (
    kernel_frame,
    kernel_mlp,
    kernel_pair,
    kernels,
    pair_entry,
    region_label,
)
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.learned.compound import kernel_classify
from impactnet.models.learned.compound.classifier import GroupClassifier
from impactnet.models.learned.compound.groups import N_GROUP_FEATURES, PartGroup
from impactnet.models.learned.mlp import MLPStack
from tests.models.learned.learned_fixtures import write_test_bundle
from tests.models.learned.test_batch import MODES, mixed
from tests.models.learned.test_mlp import random_mlp

MODULES = (kernel_mlp, kernel_frame, region_label, kernel_pair, kernel_classify)


def signatures() -> dict[str, int]:
    """Compiled signatures of every kernel of the learned runtime, by name."""
    return {f"{module.__name__}.{name}": len(value.signatures) for module in MODULES
            for name, value in vars(module).items() if isinstance(value, CPUDispatcher)}


def test_after_the_warm_up_nothing_compiles(tmp_path):
    bundle = read_bundle(write_test_bundle(tmp_path / "bundle"))  # widths 48 and 24, K = 3
    kernels.warm_up()
    warmed = signatures()
    entries = ("kernel_pair.answer_one", "kernel_pair.answer_rows",
               "kernel_pair.answer_rows_parallel", "kernel_mlp.forward_rows",
               "kernel_mlp.forward_rows_parallel", "region_label.label_rows",
               "region_label.label_rows_parallel", "compound.kernel_classify.classify_rows",
               "compound.kernel_classify.classify_rows_parallel")
    for entry in entries:
        assert warmed[f"impactnet.models.learned.{entry}"] == 1, entry
    args = mixed(PARALLEL_MIN_ROWS + 10)
    for mode in MODES:
        predictor = models.load_predictor(mode, bundle)
        predictor.predict(*args)
        predictor.predict(*(a[:3] for a in args))
        predictor(*(a[1] for a in args))  # a swapped one
        predictor(*(a[2:3] for a in args))
    mlp = random_mlp((9, 128, 128, 300))
    for n in (1, PARALLEL_MIN_ROWS):
        mlp.forward(np.ones((n, 9), np.float32))
        MLPStack([random_mlp((12, 8, 7), "relu"), random_mlp((12, 5, 5, 7))]).forward(
            np.ones((n, 12)))
        region_label.label_block(tuple(a[:n] for a in args))
        kernel_classify.classify(classifiers(), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)))
    assert signatures() == warmed


def classifiers():
    """Two classifiers of other widths than the warm-up's (3 labels, 4 slots; one without)."""
    group = PartGroup("fl", (0,), (1,), (0.1, 0.2, 0.3), (0.0, 0.0, -0.1))
    mlp = random_mlp((N_GROUP_FEATURES, 16, 16, 7), classifier=True,
                     outputs="part-labels-regions-v1")
    lo, hi = np.full(N_GROUP_FEATURES, -2.0), np.full(N_GROUP_FEATURES, 2.0)
    labelled = GroupClassifier(group, np.array([[0, 1], [0, 2], [3, 1]]), np.array([0, 1, 1, 2]),
                               np.array([40, 41, 42, 43]), mlp, 1.3, 0.2, lo, hi,
                               (-1.0, 1.0, 1.0))
    empty = GroupClassifier(group, np.zeros((0, 2), np.int64), np.zeros(0, np.int64),
                            np.zeros(0, np.int64), None, 1.0, 0.5, lo, hi)
    return kernel_classify.classifier_set([labelled, empty])


def test_the_one_pair_entry_is_closed_to_other_types():
    entry = pair_entry.one_pair_entry()
    pair = [np.ones(3), np.zeros(3), np.array([1.0, 0, 0, 0]), np.ones(3), np.zeros(3),
            np.array([1.0, 0, 0, 0])]
    with pytest.raises(TypeError):  # float32 vectors: not compiled for, never compiled
        entry(*(p.astype(np.float32) for p in pair), *pair_entry.NO_PROGRAM, 0, False,
              *[np.empty(1)] * 13)
