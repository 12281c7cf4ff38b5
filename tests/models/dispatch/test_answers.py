"""The dispatcher's answer pieces (models/dispatch/answers.py): slices land at their rows,
whatever their order, and a column one slice fills whole is kept as given."""
from __future__ import annotations

import numpy as np

from impactnet.models.dispatch.answers import CONTACT_COLUMNS, Pieces


def _no_contacts() -> dict:
    return {name: np.zeros((0, *shape), dtype) for name, dtype, shape in CONTACT_COLUMNS}


def test_a_slice_of_every_row_out_of_order_lands_row_by_row():
    pieces = Pieces(3)
    pieces.add(np.array([2, 0, 1]), {"depth": np.array([0.2, 0.0, 0.1])}, "exact",
               np.zeros(0, np.int64), {})
    np.testing.assert_array_equal(pieces.body["depth"], [0.0, 0.1, 0.2])


def test_a_column_one_slice_fills_in_order_is_kept_and_the_others_take_their_defaults():
    depth = np.array([0.0, 0.1, 0.2])
    pieces = Pieces(3)
    pieces.add(np.arange(3), {"depth": depth}, "exact", np.zeros(0, np.int64), _no_contacts())
    answers = pieces.merged()
    assert answers.body["depth"] is depth
    np.testing.assert_array_equal(answers.body["distance"], np.full(3, np.inf))
    np.testing.assert_array_equal(answers.body["feature_a"], np.full(3, -1))
