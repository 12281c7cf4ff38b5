"""Tests of models/geometry/rotations.py against scipy.spatial.transform.Rotation and invariants.

scipy stores quaternions as (x, y, z, w); its intrinsic "ZYX" order takes [yaw, pitch, roll],
so our "zyx" [roll, pitch, yaw] is scipy's "ZYX" of the reversed triple, and our "xyz" is
scipy's intrinsic "XYZ" of the same triple.
"""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation
from scipy.stats import kstest

from impactnet.models.geometry.rotations import (
    GIMBAL_LOCK_TOL,
    QUATERNION_MIN_NORM,
    ROTATION_MATRIX_TOL,
    InvalidRotationError,
    euler_to_matrix,
    euler_to_quaternion,
    matrix_to_euler,
    matrix_to_quaternion,
    quaternion_conjugate,
    quaternion_multiply,
    quaternion_to_matrix,
    random_quaternions,
    rotation_to_matrix,
    rotation_to_quaternion,
    validate_euler,
    validate_matrix,
    validate_quaternion,
)

#: Agreement of float64 results after a few dozen operations on unit-scale numbers.
ROUNDOFF_TOL = 1e-12
#: Agreement near gimbal lock, where angles (not matrices) lose digits; still far below any
#: physical relevance (radians or matrix entries).
GIMBAL_REPRODUCTION_TOL = 1e-10
#: Allowed distance (Frobenius entries) between a 1e-9-noisy matrix and its re-orthonormalised
#: rotation: the noise itself, with margin.
NOISE_RECOVERY_TOL = 1e-8
N_RANDOM = 10_000


def to_scipy(q):
    return Rotation.from_quat(np.asarray(q)[:, [1, 2, 3, 0]])


def same_rotation(q1, q2):
    """|<q1, q2>| per row: 1 when q1 and q2 are the same rotation (q and -q included)."""
    return np.abs(np.sum(q1 * q2, axis=1))


def wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture(scope="module")
def random_q():
    return random_quaternions(N_RANDOM, np.random.default_rng(20240601))


# --- quaternion <-> matrix -------------------------------------------------------------------

def test_quaternion_to_matrix_matches_scipy_on_10000_random_rotations(random_q):
    np.testing.assert_allclose(quaternion_to_matrix(random_q),
                               to_scipy(random_q).as_matrix(), atol=ROUNDOFF_TOL)


def test_one_rotation_is_the_batch_row_bit_for_bit(random_q):
    # one row takes Python floats through the same formula: it must round as the batch does
    batch = quaternion_to_matrix(random_q[:200])
    for k in range(200):
        np.testing.assert_array_equal(quaternion_to_matrix(random_q[k]), batch[k:k + 1])


def test_matrix_to_quaternion_matches_scipy_with_canonical_sign(random_q):
    matrices = to_scipy(random_q).as_matrix()
    q = matrix_to_quaternion(matrices)
    assert q.shape == (N_RANDOM, 4)
    assert np.all(q[:, 0] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(same_rotation(q, random_q), 1.0, atol=ROUNDOFF_TOL)


def test_matrix_round_trip_on_10000_random_rotations(random_q):
    matrices = quaternion_to_matrix(random_q)
    np.testing.assert_allclose(quaternion_to_matrix(matrix_to_quaternion(matrices)), matrices,
                               atol=ROUNDOFF_TOL)


def test_negated_quaternion_gives_same_matrix(random_q):
    np.testing.assert_allclose(quaternion_to_matrix(-random_q), quaternion_to_matrix(random_q),
                               atol=ROUNDOFF_TOL)


def test_quaternion_to_matrix_is_active_rotation():
    # 90 degrees about z turns body x into world y.
    q = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]
    np.testing.assert_allclose(quaternion_to_matrix(q)[0] @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                               atol=ROUNDOFF_TOL)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_matrix_round_trip_at_180_degrees_about_each_axis(axis):
    q = np.zeros(4)
    q[1 + axis] = 1.0
    matrix = quaternion_to_matrix(q)
    np.testing.assert_allclose(matrix[0], np.diag(np.where(np.arange(3) == axis, 1.0, -1.0)),
                               atol=ROUNDOFF_TOL)
    back = matrix_to_quaternion(matrix)
    np.testing.assert_array_equal(back, q[None])  # w == 0: the largest component is positive
    np.testing.assert_allclose(quaternion_to_matrix(back), matrix, atol=ROUNDOFF_TOL)


def test_matrix_round_trip_at_180_degrees_about_random_axes():
    axes = np.random.default_rng(7).normal(size=(1000, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    for angle in (np.pi, np.pi - 1e-9, np.pi - 1e-6):
        matrices = Rotation.from_rotvec(axes * angle).as_matrix()
        q = matrix_to_quaternion(matrices)
        assert np.all(np.isfinite(q)) and np.all(q[:, 0] >= 0.0)
        np.testing.assert_allclose(same_rotation(q, Rotation.from_matrix(matrices).as_quat()
                                                 [:, [3, 0, 1, 2]]), 1.0, atol=ROUNDOFF_TOL)
        np.testing.assert_allclose(quaternion_to_matrix(q), matrices, atol=ROUNDOFF_TOL)


def test_identity_in_every_representation():
    identity_q = np.array([[1.0, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(quaternion_to_matrix(identity_q), np.eye(3)[None])
    np.testing.assert_array_equal(matrix_to_quaternion(np.eye(3)), identity_q)
    np.testing.assert_array_equal(matrix_to_euler(np.eye(3)), np.zeros((1, 3)))
    for convention in ("zyx", "xyz"):
        np.testing.assert_array_equal(euler_to_matrix(np.zeros(3), convention), np.eye(3)[None])
        np.testing.assert_array_equal(euler_to_quaternion(np.zeros(3), convention), identity_q)


# --- Euler angles ----------------------------------------------------------------------------

def test_euler_zyx_matches_scipy_intrinsic_ZYX():
    rng = np.random.default_rng(11)
    euler = rng.uniform([-np.pi, -np.pi / 2, -np.pi], [np.pi, np.pi / 2, np.pi], (N_RANDOM, 3))
    reference = Rotation.from_euler("ZYX", euler[:, ::-1])
    np.testing.assert_allclose(euler_to_matrix(euler), reference.as_matrix(), atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(same_rotation(euler_to_quaternion(euler),
                                             reference.as_quat()[:, [3, 0, 1, 2]]), 1.0,
                               atol=ROUNDOFF_TOL)
    # Away from gimbal lock the angles are unique: ours must equal scipy's.
    np.testing.assert_allclose(matrix_to_euler(reference.as_matrix()),
                               reference.as_euler("ZYX")[:, ::-1], atol=1e-9)


def test_euler_xyz_matches_scipy_intrinsic_XYZ():
    rng = np.random.default_rng(12)
    euler = rng.uniform(-np.pi / 2, np.pi / 2, (N_RANDOM, 3))  # the paper's protocol range
    reference = Rotation.from_euler("XYZ", euler)
    np.testing.assert_allclose(euler_to_matrix(euler, "xyz"), reference.as_matrix(),
                               atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(quaternion_to_matrix(euler_to_quaternion(euler, "xyz")),
                               reference.as_matrix(), atol=ROUNDOFF_TOL)
    back = matrix_to_euler(reference.as_matrix(), "xyz")
    np.testing.assert_allclose(back, euler, atol=1e-9)  # unique inside (-pi/2, pi/2)^3


def test_zyx_is_the_default_convention():
    euler = np.array([0.3, -0.7, 1.1])
    np.testing.assert_array_equal(euler_to_matrix(euler), euler_to_matrix(euler, "zyx"))
    assert not np.allclose(euler_to_matrix(euler, "xyz"), euler_to_matrix(euler, "zyx"))


@pytest.mark.parametrize("convention", ["zyx", "xyz"])
def test_euler_round_trip_on_10000_random_rotations(random_q, convention):
    matrices = quaternion_to_matrix(random_q)
    euler = matrix_to_euler(matrices, convention)
    assert euler.shape == (N_RANDOM, 3)
    assert np.all(np.abs(euler[:, 1]) <= np.pi / 2)
    assert np.all(np.abs(euler[:, [0, 2]]) <= np.pi)
    np.testing.assert_allclose(euler_to_matrix(euler, convention), matrices, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(same_rotation(euler_to_quaternion(euler, convention), random_q),
                               1.0, atol=ROUNDOFF_TOL)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_gimbal_lock_puts_whole_rotation_into_yaw(sign):
    roll, yaw = 0.3, 0.5
    matrix = euler_to_matrix([roll, sign * np.pi / 2, yaw])
    euler = matrix_to_euler(matrix)
    assert np.all(np.isfinite(euler))
    # Rz(y) Ry(+-pi/2) Rx(r) = Rz(y -+ r) Ry(+-pi/2): roll 0, yaw takes the rest.
    np.testing.assert_allclose(euler[0], [0.0, sign * np.pi / 2, yaw - sign * roll],
                               atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(euler_to_matrix(euler), matrix, atol=ROUNDOFF_TOL)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_gimbal_lock_round_trip_on_scipy_matrices(sign):
    rng = np.random.default_rng(13)
    roll_yaw = rng.uniform(-np.pi, np.pi, (1000, 2))
    matrices = Rotation.from_euler("ZYX", np.stack(
        [roll_yaw[:, 1], np.full(1000, sign * np.pi / 2), roll_yaw[:, 0]], -1)).as_matrix()
    for convention in ("zyx", "xyz"):
        euler = matrix_to_euler(matrices, convention)
        assert np.all(np.isfinite(euler))
        np.testing.assert_allclose(euler_to_matrix(euler, convention), matrices,
                                   atol=ROUNDOFF_TOL)
    np.testing.assert_array_equal(matrix_to_euler(matrices)[:, 0], 0.0)
    np.testing.assert_array_equal(matrix_to_euler(matrices)[:, 1], sign * np.pi / 2)


@pytest.mark.parametrize("delta", [1e-15, 1e-13, 1e-11, 1e-9, 1e-7, 1e-5, 1e-3])
def test_near_gimbal_lock_reproduces_matrix(delta):
    rng = np.random.default_rng(14)
    n = 500
    euler = np.stack([rng.uniform(-np.pi, np.pi, n),
                      rng.choice([-1.0, 1.0], n) * (np.pi / 2 - delta),
                      rng.uniform(-np.pi, np.pi, n)], -1)
    matrices = euler_to_matrix(euler)
    back = matrix_to_euler(matrices)
    assert np.all(np.isfinite(back))
    np.testing.assert_allclose(euler_to_matrix(back), matrices, atol=GIMBAL_REPRODUCTION_TOL)
    if delta < GIMBAL_LOCK_TOL:
        np.testing.assert_array_equal(back[:, 0], 0.0)


def test_angles_near_plus_minus_pi_wrap():
    eps = 1e-12
    euler = np.array([[np.pi, 0.2, -np.pi], [np.pi - eps, -0.4, -(np.pi - eps)],
                      [-(np.pi - eps), 0.1, np.pi - eps], [3 * np.pi, 0.3, -5 * np.pi / 2]])
    matrices = euler_to_matrix(euler)
    back = matrix_to_euler(matrices)
    assert np.all(np.abs(back[:, [0, 2]]) <= np.pi)
    np.testing.assert_allclose(euler_to_matrix(back), matrices, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(np.abs(wrap(back - euler)), 0.0, atol=1e-9)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3),
       st.sampled_from(["zyx", "xyz"]))
def test_any_finite_angles_reproduce_their_matrix(euler, convention):
    matrix = euler_to_matrix(euler, convention)
    back = matrix_to_euler(matrix, convention)
    np.testing.assert_allclose(euler_to_matrix(back, convention), matrix, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(quaternion_to_matrix(euler_to_quaternion(euler, convention)),
                               matrix, atol=ROUNDOFF_TOL)


# --- algebra and sampling --------------------------------------------------------------------

def test_quaternion_multiply_composes_rotations(random_q):
    q1, q2 = random_q[:5000], random_q[5000:]
    np.testing.assert_allclose(quaternion_to_matrix(quaternion_multiply(q1, q2)),
                               quaternion_to_matrix(q1) @ quaternion_to_matrix(q2),
                               atol=ROUNDOFF_TOL)
    # One quaternion broadcasts against many.
    np.testing.assert_allclose(quaternion_multiply(q1[0], q2), quaternion_multiply(
        np.repeat(q1[:1], len(q2), axis=0), q2), atol=0.0)


def test_conjugate_is_the_inverse_rotation(random_q):
    product = quaternion_multiply(random_q, quaternion_conjugate(random_q))
    np.testing.assert_allclose(product, np.tile([1.0, 0.0, 0.0, 0.0], (N_RANDOM, 1)),
                               atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(quaternion_to_matrix(quaternion_conjugate(random_q)),
                               np.swapaxes(quaternion_to_matrix(random_q), 1, 2),
                               atol=ROUNDOFF_TOL)


def test_random_quaternions_are_uniform_on_so3_and_seeded(random_q):
    np.testing.assert_allclose(np.linalg.norm(random_q, axis=1), 1.0, atol=ROUNDOFF_TOL)
    again = random_quaternions(N_RANDOM, np.random.default_rng(20240601))
    np.testing.assert_array_equal(again, random_q)
    # Haar measure: rotation angle t in [0, pi] has CDF (t - sin t) / pi.
    angle = 2.0 * np.arccos(np.clip(np.abs(random_q[:, 0]), 0.0, 1.0))
    assert kstest(angle, lambda t: (t - np.sin(t)) / np.pi).pvalue > 1e-3
    # E[R] = 0 under Haar measure; each entry has variance 1/3, so 5 sigma of the mean:
    assert np.abs(quaternion_to_matrix(random_q).mean(axis=0)).max() < 5 * np.sqrt(
        1 / 3 / N_RANDOM)
    assert random_quaternions(0, np.random.default_rng(0)).shape == (0, 4)


# --- validation ------------------------------------------------------------------------------

def test_zero_quaternion_rejected_with_row_index():
    q = np.array([[1.0, 0, 0, 0], [0.5, 0.5, 0.5, 0.5], [0.0, 0, 0, 0], [0, 1.0, 0, 0]])
    with pytest.raises(InvalidRotationError) as info:
        validate_quaternion(q)
    assert info.value.field == "quaternion"
    np.testing.assert_array_equal(info.value.rows, [2])
    assert "norm" in str(info.value) and "2" in str(info.value)
    assert isinstance(info.value, ValueError)


def test_tiny_norm_quaternion_rejected():
    assert 1e-7 < QUATERNION_MIN_NORM
    with pytest.raises(InvalidRotationError) as info:
        validate_quaternion([1e-7, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(info.value.rows, [0])


def test_small_but_valid_norm_quaternion_is_normalised():
    q = np.array([0.0, 0.6, 0.0, 0.8]) * 1e-5
    np.testing.assert_allclose(validate_quaternion(q), [[0.0, 0.6, 0.0, 0.8]],
                               atol=ROUNDOFF_TOL)


def test_validate_quaternion_keeps_sign_and_normalises():
    q = np.array([[-2.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]])
    np.testing.assert_allclose(validate_quaternion(q), [[-1.0, 0, 0, 0], [0.5, 0.5, 0.5, 0.5]],
                               atol=ROUNDOFF_TOL)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_inputs_rejected(bad):
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    q[1, 2] = bad
    matrices = np.tile(np.eye(3), (3, 1, 1))
    matrices[2, 0, 1] = bad
    euler = np.zeros((3, 3))
    euler[0, 1] = bad
    for validate, value, field, row in ((validate_quaternion, q, "quaternion", 1),
                                        (validate_matrix, matrices, "matrix", 2),
                                        (validate_euler, euler, "euler", 0)):
        with pytest.raises(InvalidRotationError) as info:
            validate(value)
        assert info.value.field == field
        np.testing.assert_array_equal(info.value.rows, [row])
        assert "non-finite" in str(info.value)


def test_reflection_rejected():
    reflection = np.diag([1.0, 1.0, -1.0])
    with pytest.raises(InvalidRotationError, match="determinant") as info:
        validate_matrix(np.stack([np.eye(3), reflection]))
    assert info.value.field == "matrix"
    np.testing.assert_array_equal(info.value.rows, [1])


@pytest.mark.parametrize("distortion", [
    [[1.0, 1e-3, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],   # shear
    [[1.0 + 1e-4, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],  # scale
])
def test_sheared_or_scaled_matrix_rejected(distortion):
    with pytest.raises(InvalidRotationError, match="R\\^T R - I") as info:
        validate_matrix(euler_to_matrix([0.1, 0.2, 0.3])[0] @ np.array(distortion))
    np.testing.assert_array_equal(info.value.rows, [0])


def test_noisy_matrix_accepted_and_returned_orthonormal():
    rng = np.random.default_rng(15)
    clean = quaternion_to_matrix(random_quaternions(1000, rng))
    noisy = clean + rng.uniform(-1e-9, 1e-9, clean.shape)
    fixed = validate_matrix(noisy)
    assert fixed.shape == (1000, 3, 3)
    np.testing.assert_allclose(np.swapaxes(fixed, 1, 2) @ fixed, np.tile(np.eye(3), (1000, 1, 1)),
                               atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(np.linalg.det(fixed), 1.0, atol=ROUNDOFF_TOL)
    np.testing.assert_allclose(fixed, clean, atol=NOISE_RECOVERY_TOL)


def test_float32_rotation_accepted():
    matrices = quaternion_to_matrix(random_quaternions(1000, np.random.default_rng(16)))
    single = matrices.astype(np.float32)
    error = np.abs(np.swapaxes(single, 1, 2).astype(float) @ single - np.eye(3)).max()
    assert 0.0 < error < ROTATION_MATRIX_TOL
    np.testing.assert_allclose(validate_matrix(single), matrices, atol=1e-6)


def test_euler_at_exactly_half_pi_pitch_is_valid_input():
    euler = validate_euler([[0.2, np.pi / 2, 0.1], [0.2, -np.pi / 2, 0.1]])
    np.testing.assert_array_equal(euler[:, 1], [np.pi / 2, -np.pi / 2])
    matrices = rotation_to_matrix(euler=euler)
    np.testing.assert_allclose(matrices, euler_to_matrix(euler), atol=0.0)


def test_wrong_shapes_and_conventions_rejected():
    with pytest.raises(InvalidRotationError, match="shape"):
        validate_quaternion([1.0, 0.0, 0.0])
    with pytest.raises(InvalidRotationError, match="shape"):
        validate_matrix(np.eye(4))
    with pytest.raises(InvalidRotationError, match="shape"):
        quaternion_to_matrix(np.zeros((2, 2, 4)))
    with pytest.raises(InvalidRotationError) as info:
        euler_to_matrix([0.0, 0.0, 0.0], convention="ZYX")
    assert info.value.field == "euler_convention" and info.value.rows.size == 0


# --- the public entry points -----------------------------------------------------------------

@pytest.mark.parametrize("function", [rotation_to_quaternion, rotation_to_matrix])
def test_exactly_one_orientation_rule(function):
    q, matrix, euler = [1.0, 0, 0, 0], np.eye(3), [0.0, 0.0, 0.0]
    for kwargs in ({}, {"quaternion": q, "matrix": matrix}, {"matrix": matrix, "euler": euler},
                   {"quaternion": q, "euler": euler},
                   {"quaternion": q, "matrix": matrix, "euler": euler}):
        with pytest.raises(InvalidRotationError, match="exactly one") as info:
            function(**kwargs)
        assert info.value.field == "orientation"


def test_every_orientation_input_gives_the_same_rotation():
    rng = np.random.default_rng(17)
    q = random_quaternions(200, rng)
    matrices, euler = quaternion_to_matrix(q), matrix_to_euler(quaternion_to_matrix(q))
    euler_xyz = matrix_to_euler(matrices, "xyz")
    quats = [rotation_to_quaternion(quaternion=2.0 * q), rotation_to_quaternion(matrix=matrices),
             rotation_to_quaternion(euler=euler),
             rotation_to_quaternion(euler=euler_xyz, euler_convention="xyz")]
    for result in quats:
        np.testing.assert_allclose(same_rotation(result, q), 1.0, atol=ROUNDOFF_TOL)
    for result in (rotation_to_matrix(quaternion=-q), rotation_to_matrix(matrix=matrices),
                   rotation_to_matrix(euler=euler),
                   rotation_to_matrix(euler=euler_xyz, euler_convention="xyz")):
        np.testing.assert_allclose(result, matrices, atol=ROUNDOFF_TOL)
    with pytest.raises(InvalidRotationError) as info:
        rotation_to_matrix(quaternion=np.zeros(4))
    assert info.value.field == "quaternion"


def test_single_inputs_broadcast_to_batch_of_one():
    q, matrix, euler = [0.5, 0.5, 0.5, 0.5], euler_to_matrix([0.1, 0.2, 0.3])[0], [0.1, 0.2, 0.3]
    shapes = [
        (quaternion_to_matrix(q).shape, (1, 3, 3)),
        (matrix_to_quaternion(matrix).shape, (1, 4)),
        (euler_to_matrix(euler).shape, (1, 3, 3)),
        (euler_to_quaternion(euler).shape, (1, 4)),
        (matrix_to_euler(matrix).shape, (1, 3)),
        (quaternion_multiply(q, q).shape, (1, 4)),
        (quaternion_conjugate(q).shape, (1, 4)),
        (validate_quaternion(q).shape, (1, 4)),
        (validate_matrix(matrix).shape, (1, 3, 3)),
        (validate_euler(euler).shape, (1, 3)),
        (rotation_to_quaternion(euler=euler).shape, (1, 4)),
        (rotation_to_matrix(quaternion=q).shape, (1, 3, 3)),
    ]
    for got, want in shapes:
        assert got == want
    for value in (quaternion_to_matrix(q), matrix_to_euler(matrix), euler_to_quaternion(euler)):
        assert value.dtype == np.float64
