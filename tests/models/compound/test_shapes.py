"""Generated convex shapes: frustum, wedge and prism corners, their volumes against closed
forms, and the parameter named first in every refusal."""
import math

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from impactnet.models.compound import shapes


def test_a_regular_frustum_has_its_circumdiameter_height_and_tip_scale():
    points = shapes.frustum_points(0.1, 12, 0.08, tip_scale=0.5, centre=(1.0, 2.0, 3.0))
    assert points.shape == (24, 3)
    base, tip = points[:12], points[12:]
    np.testing.assert_allclose(np.hypot(base[:, 0] - 1.0, base[:, 1] - 2.0), 0.05)
    np.testing.assert_allclose(np.hypot(tip[:, 0] - 1.0, tip[:, 1] - 2.0), 0.025)
    np.testing.assert_allclose(base[:, 2], 3.0)
    np.testing.assert_allclose(tip[:, 2], 3.08)


def test_a_cone_frustum_of_many_sides_approaches_the_cone_volume():
    r, h, k = 0.05, 0.08, 0.5
    points = shapes.frustum_points(2 * r, 256, h, tip_scale=k)
    exact = math.pi * h * r * r * (1 + k + k * k) / 3
    assert ConvexHull(points).volume == pytest.approx(exact, rel=1e-3)


def test_a_stadium_frustum_spans_its_base_and_may_point_down():
    points = shapes.frustum_points([0.104, 0.056], 32, -0.06, tip_scale=0.5)
    np.testing.assert_allclose(np.ptp(points[:32, :2], axis=0), (0.104, 0.056), atol=1e-12)
    assert points[32:, 2].max() == pytest.approx(-0.06)


@pytest.mark.parametrize("high, axis, sign", [("-x", 0, -1), ("+x", 0, 1), ("-y", 1, -1),
                                              ("+y", 1, 1)])
def test_a_wedge_is_full_height_at_its_high_end_only(high, axis, sign):
    size, centre = np.array([0.3, 0.2, 0.1]), np.array([1.0, -1.0, 0.5])
    points = shapes.wedge_points(size, centre, high)
    assert points.shape == (6, 3)
    top = points[points[:, 2] == points[:, 2].max()]
    np.testing.assert_allclose(top[:, axis], centre[axis] + sign * size[axis] / 2)
    np.testing.assert_allclose(np.ptp(points, axis=0), size)
    assert ConvexHull(points).volume == pytest.approx(size.prod() / 2)


def test_a_wedge_with_a_low_height_is_a_ramp_block():
    points = shapes.wedge_points((0.3, 0.2, 0.1), low_height=0.04)
    assert points.shape == (8, 3)
    assert ConvexHull(points).volume == pytest.approx(0.3 * 0.2 * (0.1 + 0.04) / 2)


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_a_prism_extrudes_its_section_along_its_axis(axis):
    section = [[0.0, 0.0], [0.04, 0.0], [0.02, 0.03]]
    points = shapes.prism_points(section, 1.0, axis, centre=(0.5, 0.5, 0.5))
    along = "xyz".index(axis)
    np.testing.assert_allclose(np.ptp(points, axis=0)[along], 1.0)
    np.testing.assert_allclose(points[:, along].mean(), 0.5)
    assert ConvexHull(points).volume == pytest.approx(0.5 * 0.04 * 0.03)


def test_random_convex_sections_give_their_shoelace_volume_either_way_round():
    rng = np.random.default_rng(20)
    for _ in range(50):
        n = int(rng.integers(3, 40))
        angles = np.sort(rng.uniform(0, 2 * math.pi, n))
        radii = rng.uniform(0.5, 1.0)
        section = radii * np.column_stack([np.cos(angles), np.sin(angles)])
        if len(np.unique(np.round(angles, 6))) < n or np.diff(angles).max() >= math.pi:
            continue  # a repeated point or a gap of half a turn: not a strictly convex polygon
        area = 0.5 * abs(np.sum(section[:, 0] * np.roll(section[:, 1], -1)
                                - np.roll(section[:, 0], -1) * section[:, 1]))
        order = section if rng.random() < 0.5 else section[::-1]
        height = rng.uniform(0.1, 2.0)
        points = shapes.prism_points(order, height, str(rng.choice(list("xyz"))))
        assert ConvexHull(points).volume == pytest.approx(area * height, rel=1e-9)


@pytest.mark.parametrize("call, field", [
    (lambda: shapes.frustum_points(0.1, 2, 0.1), "sides"),
    (lambda: shapes.frustum_points([0.1, 0.05], 7, 0.1), "sides"),
    (lambda: shapes.frustum_points(0.1, 8, 0.0), "height"),
    (lambda: shapes.wedge_points((1, 1, 1), high="up"), "high"),
    (lambda: shapes.wedge_points((1, 1, 1), low_height=1.0), "low_height"),
    (lambda: shapes.prism_points([[0, 0], [1, 0], [0, 1]], 1.0, "w"), "axis"),
    (lambda: shapes.prism_points([[0, 0], [1, 0], [0, 1]], 0.0), "height"),
    (lambda: shapes.prism_points([[0, 0], [1, 0]], 1.0), "section"),
    (lambda: shapes.prism_points([[0, 0], [1, 0], [0.2, 0.2], [0, 1]], 1.0), r"section\[2\]"),
    (lambda: shapes.prism_points([[0, 0], [1, 0], [2, 0], [0, 1]], 1.0), r"section\[1\]"),
    (lambda: shapes.prism_points([[0, 0], [1, 0], [1, 0], [0, 1]], 1.0), r"section\[2\]"),
])
def test_a_bad_shape_parameter_is_named_first(call, field):
    with pytest.raises(ValueError, match=rf"^{field}: "):
        call()


def test_a_star_section_that_winds_twice_is_refused():
    star = [[math.cos(a), math.sin(a)] for a in 4 * math.pi * np.arange(5) / 5]
    with pytest.raises(ValueError, match="more than once"):
        shapes.prism_points(star, 1.0)
