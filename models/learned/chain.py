"""``auto``: a chain of two predictors, the committee first and the exact solver after it.

In the manner of parry's query dispatcher chain: the first link answers what it can answer
with confidence and hands every other row on; the second link, the exact solver, answers all
it is given. The committee hands on

* the rows of a pair without ``auto``'s models (no committee, or no calibrated thresholds),
* the rows of a region without a committee,
* the rows whose answer the pair's calibrated thresholds do not trust (confidence, member
  spread, depth outside the trained range, the face-face regions of
  :data:`impactnet.models.learned.kernel_pair.AUTO_EXACT_TYPES`).

Both links run in one compiled row function
(:func:`impactnet.models.learned.kernel_pair.answer_row`): a row handed on is solved there by the
exact solver's own row function, for one pair and for a batch alike.
"""
from __future__ import annotations

from impactnet.models.learned import kernel_pair as kp
from impactnet.models.learned.batch import CommitteePredictor, LearnedPredictor


class FallbackChain(LearnedPredictor):
    """The ``auto`` predictor: ``first`` (a committee) answers, the exact solver takes the rest.

    A callable with :func:`impactnet.models.box.exact.box_box`'s signature returning
    `Contacts` whose ``predictor`` names the link that answered each row ("committee" or
    "exact"); :meth:`predict` also returns the committee's spread (0 on the exact rows).
    """

    mode, kernel_mode, answered_by = "auto", kp.AUTO, "committee"

    def __init__(self, first: CommitteePredictor):
        self.first = first
        super().__init__(first.bundle, first.pairs)

    def __repr__(self) -> str:
        return f"<auto chain: committee then exact, bundle {self.version}>"
