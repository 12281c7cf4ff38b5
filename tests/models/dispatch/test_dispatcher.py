"""The one dispatcher answers box and compound pairs in one shape: a box pair's answer is the
box solver's row with its one contact, a compound pair's the oracle's summary with its part
contacts (the deepest first), rows that cannot touch cost no broadphase and still get the
separating direction of their closest part pair, the caps stop the work."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.compound import compound_answer, container, spreader
from impactnet.models.compound.candidates import TooManyCandidates
from impactnet.models.dispatch import (
    Caps,
    Dispatcher,
    Pairs,
    Shape,
    TooManyContacts,
    TooManyShapePairs,
)

LEVEL = [1.0, 0.0, 0.0, 0.0]
C40, SPREADER = Shape(container("40ft", detail=2), "container40"), \
    Shape(spreader("40ft", sides=32), "spreader")
BOX, PLANK = Shape.box([1.0, 1.0, 1.0]), Shape.box([2.0, 1.0, 0.5])
SHAPES = (C40, SPREADER, BOX, PLANK)
STACKED, LANDED = [0.0, 0.0, 2.589], [0.0, 0.0045, 1.7005]


def _pairs(a, b, position_b, quaternion_b=None) -> Pairs:
    n = len(a)
    q_b = np.tile(LEVEL, (n, 1)) if quaternion_b is None else quaternion_b
    return Pairs(SHAPES, np.asarray(a), np.asarray(b), np.zeros((n, 3)), np.tile(LEVEL, (n, 1)),
                 np.asarray(position_b, float), q_b)


def test_a_box_pair_answers_the_box_solver_s_row_and_its_one_contact():
    rng = np.random.default_rng(0)
    q = rng.normal(size=(50, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    position = rng.uniform(-1.2, 1.2, (50, 3))
    got = Dispatcher().answer(_pairs([2] * 50, [3] * 50, position, q), include=("manifold",))
    expected = box_box([1.0, 1.0, 1.0], np.zeros(3), LEVEL, [2.0, 1.0, 0.5], position, q)
    for name in ("colliding", "point", "normal", "depth"):
        np.testing.assert_array_equal(got.body[name], getattr(expected, name))
    np.testing.assert_array_equal(got.body["contact_type"], expected.contact_type_code)
    assert (np.diff(got.offsets) == expected.colliding).all()
    hit = np.flatnonzero(expected.colliding)
    np.testing.assert_array_equal(got.contacts["axis"], expected.axis[hit])
    np.testing.assert_array_equal(got.contacts["manifold_points"], expected.manifold_points[hit])
    assert set(got.part_names[got.contacts["part_a"]]) <= {"box"}
    assert (got.predictor_names[got.predictor] == "exact").all()


def test_a_compound_pair_answers_the_oracle_with_the_deepest_contact_first():
    got = Dispatcher().answer(_pairs([0, 0], [0, 1], [STACKED, LANDED]))
    for row, (b, pose) in enumerate(((C40, STACKED), (SPREADER, LANDED))):
        expected = compound_answer(C40.parts, [0, 0, 0], LEVEL, b.parts, pose, LEVEL)
        assert got.body["depth"][row] == expected.summary.depth[0]
        np.testing.assert_array_equal(got.body["point"][row], expected.summary.point[0])
        rows = slice(got.offsets[row], got.offsets[row + 1])
        depths = got.contacts["depth"][rows]
        assert (np.diff(depths) <= 0).all()  # the deepest first
        assert got.body["depth"][row] == depths[0] == got.body["distance"][row] * -1
        names = {(got.part_names[a], got.part_names[b_]) for a, b_ in
                 zip(got.contacts["part_a"][rows], got.contacts["part_b"][rows])}
        assert names == {(r["part_a"], r["part_b"]) for r in expected.contacts_of(0)}
        deepest = int(got.contacts["part_a"][rows][0])
        assert got.body["part_a"][row] == deepest
    assert (got.predictor_names[got.predictor] == "oracle").all()


def test_rows_that_cannot_touch_get_their_closest_part_pair_s_direction(monkeypatch):
    from impactnet.models.dispatch import plan

    counted = []
    real = plan.candidate_pairs
    monkeypatch.setattr(plan, "candidate_pairs", lambda *a, **k: counted.append(1) or real(*a,
                                                                                       **k))
    got = Dispatcher().answer(_pairs([2, 0], [0, 1], [[0.0, 0.0, 30.0], [0.0, 0.0, 2.5]]),
                              margin=1.0)
    assert counted == [1]  # only the spreader's row was counted
    assert not got.body["colliding"].any()
    np.testing.assert_allclose(got.body["normal"][0], [0, 0, 1], atol=1e-12)
    assert got.body["distance"][0] == np.inf  # beyond the margin
    assert 0.7 < got.body["distance"][1] < 0.73  # the twistlocks' gap over the castings
    assert np.linalg.norm(got.body["normal"][1]) == pytest.approx(1.0)


def test_rows_that_cannot_touch_beside_touching_ones_carry_the_manifold_columns_asked_for():
    """Regression: a batch asking for the manifold whose compound rows include one that cannot
    touch (no broadphase, no contacts) merged its slices without the manifold's columns."""
    got = Dispatcher().answer(_pairs([0, 0, 2], [1, 1, 3], [LANDED, [0, 0, 50.0], [0, 0, 0.7]]),
                              include=("manifold",))
    assert got.body["colliding"].tolist() == [True, False, True]
    assert np.diff(got.offsets).tolist()[1] == 0
    m = len(got.contacts["depth"])
    assert got.contacts["manifold_count"].shape == (m,)
    assert got.contacts["manifold_points"].shape == (m, 8, 3)
    assert (got.contacts["manifold_count"] >= 1).all()


def test_the_caps_stop_the_work_naming_the_row():
    stacked = _pairs([0] * 3, [0] * 3, [STACKED, [50.0, 0, 0], STACKED])
    with pytest.raises(TooManyContacts) as contacts:
        Dispatcher().answer(stacked, caps=Caps(contacts_per_pose=10))
    assert contacts.value.row == 0
    with pytest.raises(TooManyCandidates) as candidates:
        Dispatcher().answer(stacked, caps=Caps(candidates_per_request=50))
    assert candidates.value.pose is None and candidates.value.cap == 50


def _distinct_boxes_by_c40(n: int, seed: int, distance: tuple[float, float]) -> Pairs:
    """``n`` distinct box sizes, each its own shape, at ``distance`` (m, a range) from a 40 ft
    container's centre in random directions, turned about random axes."""
    rng = np.random.default_rng(seed)
    boxes = tuple(Shape.box(size) for size in rng.uniform(0.3, 2.0, (n, 3)))
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    position = direction * rng.uniform(*distance, (n, 1))
    return Pairs((C40,) + boxes, np.arange(1, n + 1), np.zeros(1, np.int64), position, q,
                 np.zeros((1, 3)), np.array([LEVEL]))


def test_many_distinct_box_sizes_apart_answer_as_each_row_alone():
    pairs = _distinct_boxes_by_c40(120, 3, (9.0, 16.0))  # past the spheres, some within 6 m
    plan = Dispatcher().plan(pairs, margin=6.0)
    assert plan.groups == [] and len(plan.apart.rows) == 120  # columns, not a group a size
    got = Dispatcher().answer(pairs, margin=6.0)
    assert 0 < np.isfinite(got.body["distance"]).sum() < 120  # both sides of the margin
    assert list(got.part_names).count("box") == 1  # every box size shares its part's code
    for row in range(120):
        alone = Dispatcher().answer(Pairs((C40, pairs.shapes[row + 1]), np.array([1]),
                                          np.array([0]), *pairs.poses(np.array([row]))),
                                    margin=6.0)
        for name in ("normal", "point", "distance", "closest_a", "closest_b"):
            np.testing.assert_array_equal(got.body[name][row], alone.body[name][0], name)
        for side in "ab":
            code, one = got.body[f"part_{side}"][row], alone.body[f"part_{side}"][0]
            assert (code < 0) == (one < 0)
            if code >= 0:
                assert got.part_names[code] == alone.part_names[one]


def test_distinct_pairs_of_shapes_that_may_touch_past_the_cap_are_refused_by_the_plan(
        monkeypatch):
    from impactnet.models.dispatch import plan as plans

    formed = []
    monkeypatch.setattr(plans, "Group", lambda *a: formed.append(1))
    pairs = _distinct_boxes_by_c40(30, 4, (1.0, 3.0))  # every row within reach
    with pytest.raises(TooManyShapePairs) as refused:
        Dispatcher().plan(pairs, caps=Caps(shape_pairs_per_request=29))
    assert (refused.value.count, refused.value.cap) == (30, 29) and formed == []
