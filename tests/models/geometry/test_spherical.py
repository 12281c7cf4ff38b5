"""Tests of models/geometry/spherical.py: round trips, the poles, the +-pi seam, wrap_angle, paper
angles."""
import numpy as np
import pytest

from impactnet.models.geometry.rotations import (
    euler_to_matrix,
    quaternion_to_matrix,
    random_quaternions,
)
from impactnet.models.geometry.spherical import (
    from_spherical,
    paper_angles,
    ray_to_box_surface,
    to_spherical,
    wrap_angle,
)

#: Agreement of float64 results after a handful of trigonometric operations (dimensionless).
ROUNDOFF_TOL = 1e-12
N_RANDOM = 10_000


@pytest.fixture(scope="module")
def rng():
    return np.random.default_rng(20240611)


def unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_round_trip_random_vectors_of_any_norm(rng):
    v = rng.standard_normal((N_RANDOM, 3)) * np.exp(rng.uniform(-20, 20, (N_RANDOM, 1)))
    az, el = to_spherical(v)
    assert np.all((az >= -np.pi) & (az <= np.pi))
    assert np.all((el >= -np.pi / 2) & (el <= np.pi / 2))
    np.testing.assert_allclose(from_spherical(az, el), unit(v), atol=ROUNDOFF_TOL)


def test_round_trip_angles_inside_the_open_ranges(rng):
    az = rng.uniform(-np.pi, np.pi, N_RANDOM)
    el = rng.uniform(-np.pi / 2 + 1e-6, np.pi / 2 - 1e-6, N_RANDOM)
    az2, el2 = to_spherical(from_spherical(az, el))
    np.testing.assert_allclose(wrap_angle(az2 - az), 0.0, atol=1e-9)
    np.testing.assert_allclose(el2, el, atol=ROUNDOFF_TOL)


def test_from_spherical_gives_unit_vectors_for_unwrapped_angles(rng):
    az, el = rng.uniform(-50, 50, (2, 1000))
    np.testing.assert_allclose(np.linalg.norm(from_spherical(az, el), axis=1), 1.0,
                               atol=ROUNDOFF_TOL)


@pytest.mark.parametrize("z, sign", [(1.0, 1), (-3.5, -1), (1e-300, 1)])
@pytest.mark.parametrize("zero", [0.0, -0.0])
def test_poles_have_exact_elevation_and_finite_azimuth(z, sign, zero):
    az, el = to_spherical([[zero, zero, z]])
    assert el[0] == sign * np.pi / 2
    assert np.isfinite(az[0]) and az[0] == 0.0


@pytest.mark.parametrize("azimuth", [-np.pi, -1.0, 0.0, 2.0, np.pi, 17.0])
def test_any_azimuth_at_a_pole_gives_the_pole(azimuth):
    np.testing.assert_allclose(from_spherical(azimuth, np.pi / 2), [[0, 0, 1]], atol=1e-16)
    np.testing.assert_allclose(from_spherical(azimuth, -np.pi / 2), [[0, 0, -1]], atol=1e-16)


def test_near_pole_round_trip_is_stable():
    eps = np.array([1e-8, 1e-12, 1e-15])
    v = np.column_stack([eps, -eps, np.ones(3)])
    az, el = to_spherical(v)
    np.testing.assert_allclose(az, -np.pi / 4, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(from_spherical(az, el), unit(v), atol=ROUNDOFF_TOL)


def test_seam_crossing_flips_azimuth_but_not_direction():
    tiny = 1e-9
    az, el = to_spherical([[-1.0, tiny, 0.2], [-1.0, -tiny, 0.2], [-1.0, 0.0, 0.2],
                           [-1.0, -0.0, 0.2]])
    assert az[0] == pytest.approx(np.pi, abs=1e-8) and az[1] == pytest.approx(-np.pi, abs=1e-8)
    assert az[2] == np.pi and az[3] == np.pi  # the seam itself, signed zero included
    assert abs(wrap_angle(az[0] - az[1])) < 3 * tiny  # raw difference ~2 pi, wrapped ~0
    back = from_spherical(az, el)
    np.testing.assert_allclose(back[0], back[1], atol=3 * tiny)
    np.testing.assert_allclose(from_spherical(-np.pi, el[2]), from_spherical(np.pi, el[2]),
                               atol=ROUNDOFF_TOL)


def test_wrap_angle_range_period_and_identity(rng):
    a = np.concatenate([rng.uniform(-1e3, 1e3, N_RANDOM),
                        [-np.pi, np.pi, 3 * np.pi, -3 * np.pi, 0.0, -0.0,
                         np.nextafter(-np.pi, -4.0), -np.pi - 1e-20, np.pi - 1e-20]])
    w = wrap_angle(a)
    assert np.all((w >= -np.pi) & (w < np.pi))
    k = (a - w) / (2 * np.pi)
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)  # differs by whole turns only
    inside = rng.uniform(-np.pi, np.pi, N_RANDOM)
    np.testing.assert_array_equal(wrap_angle(inside), inside)  # idempotent on the range
    np.testing.assert_array_equal(wrap_angle(w), w)
    assert wrap_angle(np.pi) == -np.pi and wrap_angle(-np.pi) == -np.pi


def test_wrap_angle_keeps_shape_and_nan():
    out = wrap_angle(np.array([[np.nan, 7.0], [-7.0, 0.5]]))
    assert out.shape == (2, 2) and np.isnan(out[0, 0])
    assert out[0, 1] == pytest.approx(7.0 - 2 * np.pi)


@pytest.mark.parametrize("bad", [[[0.0, 0.0, 0.0]], [[np.nan, 1.0, 0.0]], [[np.inf, 0, 0]]])
def test_to_spherical_rejects_zero_and_non_finite_vectors(bad):
    with pytest.raises(ValueError):
        to_spherical(bad)


def test_to_spherical_rejects_wrong_shape():
    with pytest.raises(ValueError):
        to_spherical(np.ones((4, 2)))


def test_paper_angles_identity_frame():
    out = paper_angles([[1.0, 0.0, 0.0], [0.0, 0.0, 5.0]], [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
                       np.zeros(3), np.eye(3))
    np.testing.assert_allclose(out, [[0.0, 0.0, np.pi / 2, 0.0], [0.0, np.pi / 2, np.pi, 0.0]],
                               atol=ROUNDOFF_TOL)


def test_paper_angles_are_in_a_frame(rng):
    n = 500
    rot = quaternion_to_matrix(random_quaternions(n, rng))
    pos = rng.uniform(-100, 100, (n, 3))
    local_p, local_n = rng.standard_normal((n, 3)), unit(rng.standard_normal((n, 3)))
    point = pos + np.einsum("nij,nj->ni", rot, local_p)
    normal = np.einsum("nij,nj->ni", rot, local_n)
    out = paper_angles(point, normal, pos, rot)
    assert out.shape == (n, 4)
    np.testing.assert_allclose(from_spherical(out[:, 0], out[:, 1]), unit(local_p), atol=1e-10)
    np.testing.assert_allclose(from_spherical(out[:, 2], out[:, 3]), local_n, atol=1e-10)


def test_paper_angles_single_rotation_broadcasts():
    rot = euler_to_matrix([0.0, 0.0, np.pi / 2])[0]  # yaw 90 degrees: A's +x is world +y
    out = paper_angles([[0.0, 2.0, 0.0]], [[0.0, 1.0, 0.0]], [0.0, 0.0, 0.0], rot)
    np.testing.assert_allclose(out, [[0.0, 0.0, 0.0, 0.0]], atol=ROUNDOFF_TOL)


def test_ray_to_box_surface_lands_on_the_surface(rng):
    size = np.array([2.0, 4.0, 0.5])
    d = rng.standard_normal((N_RANDOM, 3))
    p = ray_to_box_surface(d, size)
    np.testing.assert_allclose(np.max(np.abs(p) / (size / 2), axis=1), 1.0, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(unit(p), unit(d), atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(ray_to_box_surface([[0, 0, -3.0]], size), [[0, 0, -0.25]])
