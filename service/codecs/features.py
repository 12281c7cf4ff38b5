"""Features named for every part: a box part's by the box's fixed ids (``face +z``,
``edge x(+y,-z)``, ``vertex (+,-,+)``), a convex part's by its hull's ids (``face 3``,
``edge 17``, ``vertex 40``; faces first, then edges, then vertices), ``none`` for -1.

The rule is :meth:`impactnet.models.dispatch.Shape.feature` (each shape names a feature once);
here it is applied to an answer's part codes (:class:`Labeller`), and to columns of them, once
per distinct (part, id) (:func:`labels`).

An answer's feature is ``{id, name, kind}`` everywhere: one object in a single pair's answer,
one column per key in a batch's (``{"id": [...], "name": [...], "kind": [...]}``), with the
part named beside it at the body level (``part``).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.dispatch import Answers

#: The name and kind of a missing feature (a part code or an id of -1).
NONE = ("none", "none")


class Labeller:
    """(name, kind) of a feature id of a part code of one answer (each shape names a feature
    once: :meth:`~impactnet.models.dispatch.Shape.feature`)."""

    def __init__(self, answers: Answers) -> None:
        self.shapes = answers.shapes
        self.part_index = answers.part_index.tolist()

    def __call__(self, part: int, feature_id: int) -> tuple[str, str]:
        if part < 0 or feature_id < 0:
            return NONE
        return self.shapes[part].feature(self.part_index[part], feature_id)


def labels(label: Labeller, parts: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(names (k,), kinds (k,)) object arrays of features ``ids`` (k,) of part codes ``parts``
    (k,), each distinct (part, id) named once by ``label``."""
    parts, ids = np.asarray(parts, np.int64), np.asarray(ids, np.int64)
    if not len(ids):
        return np.zeros(0, object), np.zeros(0, object)
    # one key per (part, id): ids above -1 and below the largest id + 2, parts above -1
    width = int(ids.max()) + 2
    unique, inverse = np.unique((parts + 1) * width + ids + 1, return_inverse=True)
    named = [label(int(k // width) - 1, int(k % width) - 1) for k in unique.tolist()]
    names = np.array([n for n, _ in named], dtype=object)
    kinds = np.array([k for _, k in named], dtype=object)
    inverse = inverse.reshape(-1)
    return names[inverse], kinds[inverse]
