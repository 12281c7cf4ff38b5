"""``auto``: a chain of two predictors, the committee first and the exact solver after it.

In the manner of parry's query dispatcher chain: the first link answers what it can answer
with confidence and hands every other row on; the second link, the exact solver, answers all
it is given. The committee hands on

* the rows of a pair without ``auto``'s models (no committee, or no calibrated thresholds),
* the rows of a region without a committee,
* the rows whose answer the pair's calibrated thresholds do not trust (confidence, member
  spread, depth outside the trained range, the face-face regions of
  :data:`impactnet.models.learned.pair_runtime.AUTO_EXACT_TYPES`).

For one pair, the committee's region labeller has already run the separating-axis test and its
tie rule; the exact link finishes from that decision
(:func:`impactnet.models.box.decision.answer_one`). A batch hands
its declined rows to :func:`impactnet.models.box.exact.box_box` in one vectorised call.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.decision import answer_one, box_box_one, single_pair
from impactnet.models.learned import pose_columns as pc
from impactnet.models.learned.batch import CommitteePredictor, exact_fill
from impactnet.models.learned.one_pair import Prediction, predict_one


class FallbackChain:
    """The ``auto`` predictor: ``first`` (a committee) answers, the exact solver takes the rest.

    A callable with :func:`impactnet.models.box.exact.box_box`'s signature returning
    `Contacts` whose ``predictor`` names the link that answered each row ("committee" or
    "exact"); :meth:`predict` also returns the committee's spread.
    """

    mode = "auto"

    def __init__(self, first: CommitteePredictor):
        self.first = first
        self.bundle, self.version, self.pairs = first.bundle, first.version, first.pairs

    def __repr__(self) -> str:
        return f"<auto chain: committee then exact, bundle {self.version}>"

    def __call__(self, size_a, position_a, quaternion_a, size_b, position_b,
                 quaternion_b) -> ct.Contacts:
        values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
        one = single_pair(*values)
        if one is None:
            return self._batch(values).contacts
        answer = predict_one(self.first, one, confident_only=True)
        if answer[0] is not None:
            return answer[0]
        return _exact_one(one, answer[1])

    def predict(self, size_a, position_a, quaternion_a, size_b, position_b,
                quaternion_b) -> Prediction:
        """Contacts of N pairs with the committee's spread (0 on the exact rows)."""
        values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
        one = single_pair(*values)
        if one is None:
            return self._batch(values)
        answer = predict_one(self.first, one, confident_only=True)
        if answer[0] is None:
            return Prediction(_exact_one(one, answer[1]), np.zeros(1), np.zeros(1))
        return Prediction(answer[0], np.array([answer[1]]), np.array([answer[2]]))

    def _batch(self, values) -> Prediction:
        inputs = pc.checked_inputs(*values)
        out = self.first.answer(inputs, spread=True)
        exact_fill(out, inputs, out.unsupported | out.unknown | out.unsure)
        return out.prediction()


def _exact_one(values, decision) -> ct.Contacts:
    """The exact link for one pair: finish from the labeller's decision, or decide first."""
    if decision is None:
        return box_box_one(values)
    return answer_one(decision)
