"""A frame in one call (issue #34): the pairs it answers are exactly the pairs of bodies that
touch or lie within the margin (checked against every pair of the frame), and each answers what
the pairwise dispatcher answers for it."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from impactnet.models.dispatch import Dispatcher, Pairs
from impactnet.models.dispatch.shapes import Shape, scene_shapes
from impactnet.models.frame import Bodies, DuplicateBodyId, answer_frame, frame_pairs
from impactnet.models.frame.yard import YardLayout, yard
from impactnet.models.scenes import load_scene

SMALL = YardLayout(rows=2, cols=3, max_height=4, guided_stacks=1)


@functools.cache
def shapes(scene: str) -> dict:
    return scene_shapes(load_scene(scene))


def small_yard(scene: str, seed: int, static_world: bool, gap: float = 0.05) -> Bodies:
    named = shapes(scene)
    layout = YardLayout(**{**SMALL.__dict__, "spreader_gap": gap})
    guide = "cell_guide" if "cell_guide" in named else None
    return yard(named, layout, seed, guide=guide).frame(static_world)


def every_pair(bodies: Bodies, margin: float):
    """The answers of every pair of the frame that the static flags allow (the reference)."""
    i, j = np.triu_indices(len(bodies), 1)
    keep = ~(bodies.static[i] & bodies.static[j])
    i, j = i[keep], j[keep]
    pairs = Pairs(bodies.shapes, bodies.shape[i], bodies.shape[j], bodies.position[i],
                  bodies.quaternion[i], bodies.position[j], bodies.quaternion[j])
    answers = Dispatcher().answer(pairs, "exact", (), margin)
    hit = answers.body["colliding"] | np.isfinite(answers.body["distance"])
    return np.stack([i[hit], j[hit]], axis=1), answers, np.flatnonzero(hit)


@pytest.mark.parametrize("scene", ["quay_crane", "quay_crane_detail"])
@pytest.mark.parametrize("static_world", [False, True])
@pytest.mark.parametrize("margin", [0.0, 0.3])
def test_a_frame_answers_exactly_the_pairs_that_touch_or_lie_within_the_margin(
        scene, static_world, margin):
    bodies = small_yard(scene, seed=3, static_world=static_world)
    frame = answer_frame(Dispatcher(), bodies, margin=margin)
    expected, reference, rows = every_pair(bodies, margin)
    np.testing.assert_array_equal(frame.index, expected)
    for name, column in frame.answers.body.items():  # the same answers, bit for bit
        np.testing.assert_array_equal(column, reference.body[name][rows], err_msg=name)
    np.testing.assert_array_equal(frame.answers.offsets,
                                  reference.take(rows).offsets)
    if not static_world:
        stacked = frame.answers.body["colliding"].sum()
        assert stacked >= len(bodies) - 2 * SMALL.rows * SMALL.cols  # every stacked container
    else:
        assert not (bodies.static[frame.index[:, 0]] & bodies.static[frame.index[:, 1]]).any()


def test_the_spreader_gap_is_reported_within_the_margin_and_dropped_beyond_it():
    bodies = small_yard("quay_crane", seed=1, static_world=True, gap=0.2)
    near = answer_frame(Dispatcher(), bodies, margin=0.3)
    far = answer_frame(Dispatcher(), bodies, margin=0.1)
    ids_a, ids_b = near.ids
    spreader = np.flatnonzero(ids_b == "s1")
    assert len(spreader) == 1
    np.testing.assert_allclose(near.answers.body["distance"][spreader], 0.2, atol=1e-9)
    assert "s1" not in set(far.ids[1].tolist())


def test_the_filter_and_the_allowed_table_drop_pairs():
    box = Shape.box((1.0, 1.0, 1.0), transient=False)
    positions = np.array([[0, 0, 0], [0.9, 0, 0], [1.8, 0, 0]], float)
    quaternions = np.tile([1.0, 0, 0, 0], (3, 1))
    plain = Bodies(("a", "b", "c"), (box,), np.zeros(3, int), positions, quaternions)
    assert frame_pairs(plain).index.tolist() == [[0, 1], [1, 2]]
    masked = Bodies(("a", "b", "c"), (box,), np.zeros(3, int), positions, quaternions,
                    contype=[1, 2, 2], conaffinity=[1, 2, 2])
    assert frame_pairs(masked).index.tolist() == [[1, 2]]
    assert frame_pairs(plain, allowed=np.zeros((1, 1), bool)).index.tolist() == []


def test_a_world_joined_to_moving_bodies_is_static_and_ids_stay_unique():
    box = Shape.box((1.0, 1.0, 1.0), transient=False)
    world = Bodies(("w1", "w2"), (box,), np.zeros(2, int), np.zeros((2, 3)),
                   np.tile([1.0, 0, 0, 0], (2, 1)))
    moving = Bodies(("m1",), (box,), np.zeros(1, int), np.zeros((1, 3)), [[1.0, 0, 0, 0]])
    joined = world.joined(moving)
    assert joined.ids == ("w1", "w2", "m1") and joined.static.tolist() == [True, True, False]
    assert frame_pairs(joined).index.tolist() == [[0, 2], [1, 2]]
    with pytest.raises(DuplicateBodyId):
        world.joined(Bodies(("w2",), (box,), np.zeros(1, int), np.zeros((1, 3)),
                            [[1.0, 0, 0, 0]]))


@pytest.mark.parametrize("margin, asked", [(0.0, False), (0.3, True)])
def test_a_frame_at_margin_0_asks_no_gap_of_the_compound_pairs_it_drops(margin, asked,
                                                                        monkeypatch):
    from impactnet.models.dispatch import solve as dispatch_solve

    calls = []
    gaps = dispatch_solve.bodies_gaps
    monkeypatch.setattr(dispatch_solve, "bodies_gaps",
                        lambda *args: calls.append(len(args[1])) or gaps(*args))
    bodies = small_yard("quay_crane_detail", seed=3, static_world=False, gap=0.2)
    frame = answer_frame(Dispatcher(), bodies, margin=margin)
    assert bool(calls) is asked  # the spreader 0.2 m above its container: apart, a compound
    assert frame.answers.body["colliding"].any()  # pair; the stacks touch either way
    Dispatcher().answer(frame_pairs(bodies, margin).pairs, "exact", (), margin)
    assert calls  # the pairwise API gives the same pairs their separating direction
