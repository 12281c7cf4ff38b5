"""The gap between two bodies made of parts (branch and bound over part pairs) equals the
smallest gap of an exhaustive pass over every part pair, names that pair, and stops at the
limit."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.compound import cell_guide, container, spreader
from impactnet.models.compound.body_table import body_table
from impactnet.models.distance.bodies import body_gaps
from impactnet.models.distance.query import polytope_gaps

LEVEL = [1.0, 0.0, 0.0, 0.0]


def _poses(n: int, seed: int, centre, spread: float, tilt: float = 0.05):
    rng = np.random.default_rng(seed)
    position = np.asarray(centre) + rng.uniform(-spread, spread, (n, 3))
    q = np.concatenate([np.ones((n, 1)), rng.normal(0, tilt, (n, 3))], axis=1)
    return position, q / np.linalg.norm(q, axis=1)[:, None]


def _exhaustive(table_a, table_b, position_b, quaternion_b):
    """The smallest gap over every part pair, each solved alone by the distance query's own
    entry (A at the origin)."""
    best = np.full(len(position_b), np.inf)
    for hull_a in table_a.hulls:
        for hull_b in table_b.hulls:
            gaps = polytope_gaps(hull_a.vertices, hull_b.vertices, np.zeros(3), LEVEL,
                                 position_b, quaternion_b)
            best = np.minimum(best, gaps.distance)
    return best


@pytest.mark.parametrize("bodies, centre", [
    ((container("40ft", detail=1), spreader("40ft", sides=8)), [0.0, 0.0, 2.2]),
    ((cell_guide(), container("20ft", detail=1)), [1.6, 1.6, 0.0]),
])
def test_the_branch_and_bound_gap_is_the_smallest_over_every_part_pair(bodies, centre):
    table_a, table_b = (body_table(b) for b in bodies)
    position, q = _poses(60, 3, centre, 0.3)
    got = body_gaps(table_a, table_b, np.zeros((60, 3)), np.tile(LEVEL, (60, 1)), position, q)
    np.testing.assert_allclose(got.distance, _exhaustive(table_a, table_b, position, q),
                               atol=1e-12)
    apart = got.distance > 0
    assert (got.part_a[apart] >= 0).all() and (got.part_b[apart] >= 0).all()
    np.testing.assert_allclose(np.linalg.norm(got.direction[apart], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(got.point_b - got.point_a,
                               got.distance[:, None] * got.direction, atol=1e-9)


def test_pairs_beyond_the_limit_answer_no_part_pair():
    table = body_table(container("20ft", detail=1))
    position = np.array([[0.0, 0.0, 3.0], [0.0, 0.0, 2.7]])  # 0.409 m and 0.109 m apart
    q = np.tile(LEVEL, (2, 1))
    got = body_gaps(table, table, np.zeros((2, 3)), q, position, q, limit=0.2)
    assert got.distance[0] == np.inf and got.part_a[0] == -1
    assert got.distance[1] == pytest.approx(2.7 - 2.591, abs=1e-12)


def test_far_from_the_origin_the_gap_is_the_same():
    table = body_table(container("20ft", detail=1))
    q = np.tile(LEVEL, (1, 1))
    near = body_gaps(table, table, np.zeros((1, 3)), q, np.array([[0.1, 0.2, 2.8]]), q)
    far = body_gaps(table, table, np.full((1, 3), 1e6), q, 1e6 + np.array([[0.1, 0.2, 2.8]]), q)
    assert far.distance[0] == pytest.approx(near.distance[0], abs=1e-9)


def test_a_level_spreader_over_a_container_answers_the_centroid_of_its_four_heads():
    """The four twistlock heads are equally close (a tie of rounding): the closest points are
    their mean, centred over the container; turned a little, one head is closest alone."""
    box, lifter = body_table(container("40ft", detail=1)), body_table(spreader("40ft", sides=8))
    lowest = min(hull.vertices[:, 2].min() for hull in lifter.hulls)  # the heads' tips
    height = 2.591 / 2 + 0.02 - lowest  # the tips 20 mm above the castings
    centred = body_gaps(box, lifter, np.zeros((1, 3)), [LEVEL], [[0.0, 0.0, height]], [LEVEL])
    np.testing.assert_allclose(centred.point_a[0, :2], 0.0, atol=1e-9)
    np.testing.assert_allclose(centred.point_b[0, :2], 0.0, atol=1e-9)
    turn = 1e-3
    q = [np.cos(turn / 2), 0.0, np.sin(turn / 2), 0.0]  # about y: one end lower
    tilted = body_gaps(box, lifter, np.zeros((1, 3)), [LEVEL], [[0.0, 0.0, height]], [q])
    assert abs(tilted.point_a[0, 0]) > 5.0  # at one end: one head pair, no mean
    assert tilted.distance[0] < centred.distance[0]
