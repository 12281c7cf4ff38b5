"""Continuity through the moment of contact: B swept towards A along a line, the distance
falling linearly to 0 and the point moving continuously (a bounded jump per step), then the
pair colliding (distance 0, direction 0, a point of both bodies).

* Straight along the closest direction (random poses of every kind): the distance falls by the
  step exactly, A's closest point stays where it is and the midpoint moves half a step.
* A parallel-face approach, straight down and obliquely (a box turned about the vertical over a
  larger box's top face): the point is the footprints' overlap centroid on the mid-plane, and
  moves no more per step than the overlap's changes allow (the step times :data:`JUMP_GAIN`).
"""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.distance.query import PolytopePair
from tests.models.distance.scenarios import KINDS, box_corners, cases
from tests.models.distance.test_gap_regions import about

#: Steps of a sweep, and the steps past the moment of contact.
STEPS, PAST = 400, 20
#: Largest move of the point per unit of B's move on a parallel-face sweep: the centroid of
#: an overlap of two rectangles moves at most as fast as one of them (1), a turned one's
#: corner clipping can add a little; a jump to another feature would be of the bodies' size.
JUMP_GAIN = 2.0


def _sweep(pair, pose_a, start_b, rotation_b, way, length):
    """The gaps of B moved from ``start_b`` along ``way`` (unit) by ``length`` in
    :data:`STEPS` steps, and :data:`PAST` steps more."""
    s = np.arange(STEPS + PAST + 1) * (length / STEPS)
    positions = start_b + s[:, None] * way
    n = len(s)
    return s, pair.gaps(np.broadcast_to(pose_a[0], (n, 3)), pose_a[1], positions, rotation_b)


@pytest.mark.parametrize("kind", KINDS)
def test_along_the_closest_direction_the_distance_falls_by_the_step(kind):
    for case in cases(kind, shapes=3, poses=4, seed=501):
        pair = PolytopePair(case.vertices_a, case.vertices_b)
        first = pair.gaps(case.position_a, case.rotation_a, case.position_b, case.rotation_b)
        for i in np.flatnonzero(first.distance > 1e-3):
            d0 = first.distance[i]
            s, g = _sweep(pair, (case.position_a[i], case.rotation_a[i]), case.position_b[i],
                          case.rotation_b[i], -first.direction[i], d0)
            ahead = s < d0 - 1e-9 * d0
            np.testing.assert_allclose(g.distance[ahead], d0 - s[ahead], atol=1e-12)
            assert (g.colliding == ~ahead).all() and (g.distance[~ahead] == 0.0).all()
            assert np.abs(g.point_a[ahead] - first.point_a[i]).max() <= 1e-9
            steps = np.linalg.norm(np.diff(g.point[ahead], axis=0), axis=1)
            assert steps.max() <= 0.5 * d0 / STEPS + 1e-9


@pytest.mark.parametrize("angle,lateral", [(0.0, (0.0, 0.0)), (0.4, (0.0, 0.0)),
                                           (0.4, (1.5, 0.4)), (1.1, (-2.0, 1.0))])
def test_a_parallel_face_approach_moves_the_centroid_continuously_through_contact(
        angle, lateral):
    pair = PolytopePair(box_corners([4.0, 3.0, 2.0]), box_corners([2.5, 1.2, 0.6]))
    start = np.array([-0.5 * lateral[0] + 0.6, -0.5 * lateral[1] - 0.3, 1.3 + 0.2])
    way = np.array([lateral[0], lateral[1], -0.2])
    length = float(np.linalg.norm(way))
    s, g = _sweep(pair, (np.zeros(3), np.eye(3)), start, about(2, angle), way / length, length)
    height = 0.2 - s * (0.2 / length)  # the gap between B's bottom and A's top face
    ahead = height > 1e-12
    np.testing.assert_allclose(g.distance[ahead], height[ahead], atol=1e-12)
    assert g.colliding[~ahead].all() and (g.distance[~ahead] == 0.0).all()
    np.testing.assert_allclose(g.point[ahead, 2], 1.0 + 0.5 * height[ahead], atol=1e-12)
    step = length / STEPS
    upto = np.flatnonzero(~ahead)[0] + 1  # through the moment of contact
    jumps = np.linalg.norm(np.diff(g.point[:upto], axis=0), axis=1)
    assert jumps.max() <= JUMP_GAIN * step
    past = g.point[upto:]  # overlapping: a point of both boxes
    bottom = start[2] - 0.3 + s[upto:] * way[2] / length
    assert ((past[:, 2] <= 1.0 + 1e-12) & (past[:, 2] >= bottom - 1e-12)).all()
