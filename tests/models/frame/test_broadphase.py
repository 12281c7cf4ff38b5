"""The broadphase over bodies finds exactly the pairs whose oriented bounds (grown by the
margin) overlap, against a brute-force reference on seeded random worlds; the filter and the
static world are applied; the cost grows with the pairs found, not with n squared."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.frame.broadphase import body_pairs, world_bounds
from impactnet.models.geometry.rotations import quaternion_to_matrix


def _world(n: int, seed: int, spread: float = 20.0):
    rng = np.random.default_rng(seed)
    centre = rng.normal(0, 0.1, (n, 3))
    half = rng.uniform(0.2, 3.0, (n, 3))
    position = rng.uniform(-spread, spread, (n, 3))
    q = rng.normal(size=(n, 4))
    return centre, half, position, quaternion_to_matrix(q / np.linalg.norm(q, axis=1)[:, None])


def _brute_force(centre, half, position, rotation, margin):
    n = len(position)
    lo, hi = np.empty((n, 3)), np.empty((n, 3))
    world_bounds(centre, half, position, rotation, margin, lo, hi)
    i, j = np.triu_indices(n, 1)
    keep = ((lo[j] <= hi[i]) & (lo[i] <= hi[j])).all(axis=1)
    return np.stack([i[keep], j[keep]], axis=1)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("margin", [0.0, 0.5])
def test_the_sweep_finds_exactly_the_overlapping_bounds(seed, margin):
    world = _world(300, seed)
    np.testing.assert_array_equal(body_pairs(*world, margin=margin),
                                  _brute_force(*world, margin))


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("moving", [1, 7, 150])
def test_with_a_static_world_the_sweep_finds_exactly_the_pairs_with_a_moving_body(seed, moving):
    world = _world(300, 10 + seed)
    static = np.ones(300, bool)
    static[np.random.default_rng(seed).choice(300, moving, replace=False)] = False
    expected = _brute_force(*world, 0.5)
    expected = expected[~(static[expected[:, 0]] & static[expected[:, 1]])]
    np.testing.assert_array_equal(body_pairs(*world, margin=0.5, static=static), expected)


def test_a_long_static_body_is_found_from_a_moving_body_far_along_it():
    eye = np.broadcast_to(np.eye(3), (3, 3, 3))
    half = np.array([[500.0, 1, 1], [1, 1, 1], [1, 1, 1]])  # a 1 km quay, two boxes on it
    position = np.array([[0.0, 0, 0], [-480.0, 0, 1.5], [490.0, 0, 1.5]])
    pairs = body_pairs(np.zeros((3, 3)), half, position, eye, static=[True, False, False])
    assert pairs.tolist() == [[0, 1], [0, 2]]


def test_world_bounds_hold_every_corner_of_the_oriented_box():
    centre, half, position, rotation = _world(200, 7)
    lo, hi = np.empty((200, 3)), np.empty((200, 3))
    world_bounds(centre, half, position, rotation, 0.0, lo, hi)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    corners = (position[:, None] + np.einsum("nij,nkj->nki", rotation,
                                             centre[:, None] + signs[None] * half[:, None]))
    assert (corners >= lo[:, None] - 1e-12).all() and (corners <= hi[:, None] + 1e-12).all()
    touching = np.isclose(corners, lo[:, None], atol=1e-9).any(axis=1)
    assert touching.all()  # the bounds are tight: a corner on every low face


def test_two_boxes_within_the_margin_are_a_pair_and_farther_ones_are_not():
    eye = np.broadcast_to(np.eye(3), (2, 3, 3))
    half = np.ones((2, 3))
    near = body_pairs(np.zeros((2, 3)), half, [[0, 0, 0], [2.4, 0, 0]], eye, margin=0.5)
    far = body_pairs(np.zeros((2, 3)), half, [[0, 0, 0], [2.6, 0, 0]], eye, margin=0.5)
    assert near.tolist() == [[0, 1]] and far.tolist() == []


def test_the_filter_and_the_static_world_drop_pairs():
    eye = np.broadcast_to(np.eye(3), (3, 3, 3))
    args = (np.zeros((3, 3)), np.ones((3, 3)), [[0, 0, 0], [1, 0, 0], [2, 0, 0]], eye)
    assert body_pairs(*args).tolist() == [[0, 1], [0, 2], [1, 2]]
    types, affinities = [1, 2, 2], [1, 1, 1]  # 1 and 2 are 2/1: they never meet
    assert body_pairs(*args, types=types, affinities=affinities).tolist() == [[0, 1], [0, 2]]
    static = [True, True, False]  # 0 and 1 are the yard
    assert body_pairs(*args, static=static).tolist() == [[0, 2], [1, 2]]


def test_many_pairs_grow_the_buffer():
    eye = np.broadcast_to(np.eye(3), (200, 3, 3))
    pairs = body_pairs(np.zeros((200, 3)), np.ones((200, 3)), np.zeros((200, 3)), eye)
    assert len(pairs) == 200 * 199 // 2  # every pair: more than the first buffer holds
