"""The predictors' column-wise canonical frame against the reference
(impactnet.models.learned.canonical),
their input validation against the exact solver's, and the one-pair path's."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models.box.decision import single_pair
from impactnet.models.box.exact import InvalidBoxError, prepare_inputs
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import InvalidRotationError
from impactnet.models.learned import canonical as cn
from impactnet.models.learned import pose_columns as pc
from tests.models.helpers import KEYS, labelled_rows

#: Agreement of the float32 column path's features with the float64 reference: a few float32
#: rounding units of quantities of magnitude 1.
FEATURE_TOL = 2e-6
SIZE_A, SIZE_B = [6.058, 2.438, 2.591], [12.0, 2.35, 0.8]


@pytest.fixture(scope="module")
def rows():
    rows = labelled_rows(SIZE_A, SIZE_B, 3000, 4)
    rng = np.random.default_rng(0)
    shift = rng.normal(size=3) * 1e5  # far from the origin: the offset is taken in float64
    rows["position_a"] = rows["position_a"] + shift
    rows["position_b"] = rows["position_b"] + shift
    rows["quaternion_a"] = rows["quaternion_a"] * rng.uniform(0.5, 3.0, (3000, 1))  # unnormalised
    rows["point"] = rows["point"] + shift
    return rows


def column_features(args, block=pc.ROW_BLOCK):
    inputs = pc.checked_inputs(*args)
    features = np.empty((inputs.n, 12), np.float32)
    frames = [pc.canonical_block(inputs, s, min(inputs.n, s + block), 0.0, features[s:s + block])
              for s in range(0, inputs.n, block)]
    return inputs, features, frames


@pytest.mark.parametrize("block", [7, pc.ROW_BLOCK])
def test_features_match_the_reference(rows, block):
    args = [rows[k] for k in KEYS]
    pose = cn.relative_pose(*args)
    c = cn.canonicalize(pose.rotation, pose.translation)
    reference = cn.pose_features(c, pose.half_a, pose.half_b)
    scale = pose.half_a.max(1)[0] + pose.half_b.max(1)[0]
    inputs = pc.checked_inputs(*args)
    features = np.empty((inputs.n, 12), np.float32)
    flips = []
    for s in range(0, inputs.n, block):
        frame = pc.canonical_block(inputs, s, min(inputs.n, s + block), 1.0 / scale,
                                   features[s:s + block])
        flips.append((frame.flip_a, frame.flip_b))
    near_tie = (np.abs(pose.translation) < 1e-5 * scale).any(1)  # a sign may differ there
    assert near_tie.mean() < 0.01
    np.testing.assert_allclose(features[~near_tie], reference[~near_tie], atol=FEATURE_TOL)
    flip_a = np.concatenate([f[0] for f in flips])
    flip_b = np.concatenate([f[1] for f in flips])
    np.testing.assert_array_equal(flip_a[~near_tie], bf.sign_flip_index(c.S)[~near_tie])
    np.testing.assert_array_equal(flip_b[~near_tie], bf.sign_flip_index(c.T)[~near_tie])


def test_one_row_inputs_broadcast(rows):
    args = [rows[k][:50] for k in KEYS]
    args[0] = np.array(SIZE_A)
    args[2] = args[2][7]  # one orientation of A for every row
    full = list(args)
    full[0] = np.broadcast_to(args[0], (50, 3))
    full[2] = np.broadcast_to(args[2], (50, 4))
    np.testing.assert_array_equal(column_features(args)[1], column_features(full)[1])


def test_world_block_inverts_the_targets(rows):
    args = [rows[k] for k in KEYS]
    pose = cn.relative_pose(*args)
    c = cn.canonicalize(pose.rotation, pose.translation)
    targets = cn.contact_targets(rows["point"], rows["normal"], rows["depth"],
                                 rows["position_a"], rows["quaternion_a"], c, pose.half_a,
                                 pose.half_b)
    scale = float(pose.half_a.max(1)[0] + pose.half_b.max(1)[0])
    inputs, _, frames = column_features(args)
    point, normal = np.empty((inputs.n, 3)), np.empty((inputs.n, 3))
    for s, frame in zip(range(0, inputs.n, pc.ROW_BLOCK), frames):
        e = min(inputs.n, s + pc.ROW_BLOCK)
        columns = np.ascontiguousarray(targets[s:e].T)
        pc.world_block(columns, frame, pc.block_rows(inputs.position_a, s, e), scale, point[s:e],
                       normal[s:e])
    hit = rows["colliding"] & ~(np.abs(pose.translation) < 1e-5 * scale).any(1)
    np.testing.assert_allclose(normal[hit], rows["normal"][hit], atol=2e-6)
    np.testing.assert_allclose(point[hit], rows["point"][hit], atol=2e-6 * scale + 1e-10 * 1e5)


def test_short_normals_fall_back():
    args = [np.array(SIZE_A), np.zeros(3), [1.0, 0, 0, 0], np.array(SIZE_B), [0.1, 0.2, 2.0],
            [1.0, 0, 0, 0]]
    inputs, _, frames = column_features([np.atleast_2d(a) for a in args])
    columns = np.zeros((7, 1), np.float32)
    point, normal = np.empty((1, 3)), np.empty((1, 3))
    pc.world_block(columns, frames[0], inputs.position_a[:1], 1.0, point, normal)
    np.testing.assert_allclose(normal[0], cn.FALLBACK_NORMAL, atol=1e-6)
    assert np.isfinite(point).all()


def _args(**change):
    args = {"size_a": [[1.0, 2.0, 3.0]] * 2, "position_a": [[0.0, 0.0, 0.0]] * 2,
            "quaternion_a": [[1.0, 0.0, 0.0, 0.0]] * 2, "size_b": [1.0, 1.0, 1.0],
            "position_b": [[0.5, 0.2, 1.9]] * 2, "quaternion_b": [[0.0, 0.0, 0.0, 2.0]] * 2}
    args.update(change)
    return [np.array(args[k], dtype=float) for k in KEYS]


@pytest.mark.parametrize("change, error", [
    ({"position_a": [[np.nan, 0, 0], [0, 0, 0]]}, InvalidBoxError),
    ({"size_b": [0.0, 1.0, 1.0]}, InvalidBoxError),
    ({"size_a": [[1.0, 2.0, 3e7]] * 2}, InvalidBoxError),
    ({"position_b": [[0, 0, 2e9]] * 2}, InvalidBoxError),
    ({"quaternion_b": [[0.0, 0.0, 0.0, 0.0]] * 2}, InvalidRotationError),
    ({"quaternion_a": [[1.0, 0.0, 0.0]] * 2}, InvalidBoxError),
    ({"position_b": [[0.5, 0.2, 1.9]] * 3}, InvalidBoxError),
])
def test_invalid_inputs_raise_as_the_exact_solver(change, error):
    args = _args(**change)
    with pytest.raises(error) as expected:
        prepare_inputs(*args)
    with pytest.raises(error) as got:
        pc.checked_inputs(*args)
    assert str(got.value) == str(expected.value)


def test_valid_inputs_are_accepted_unnormalised():
    inputs = pc.checked_inputs(*_args())
    assert inputs.n == 2 and len(inputs.size_b) == 1
    np.testing.assert_array_equal(inputs.norm2_b, [4.0, 4.0])
    assert inputs.swapped().size_a.shape == (1, 3) and inputs.take(np.array([1])).n == 1


def test_the_one_pair_validator_declines_batches():
    assert single_pair(*_args()) is None
    assert single_pair(*([[[1.0, 2.0, 3.0]] * 2] + _args()[1:])) is None
