"""The committee's region classifier (the exact labeller) decides as the exact solver does."""
import numpy as np
import pytest

from models import local_frame as lf
from models.exact import box_box_batch, prepare_inputs
from models.exact_scalar import box_box_one, single_pair
from models.pose_columns import checked_inputs
from models.region_label import input_block, label_block, label_one
from tests.models.helpers import KEYS
from tests.models.test_exact_scalar import family_poses
from training.datagen import generate_pairs

#: Agreement (x the pair's size) of a point computed along two paths of float64 arithmetic.
POINT_AGREEMENT_REL = 1e-9
#: A point farther than this (x the size) from the exact one was changed by the clipping.
CLIPPED_REL = 1e-6
#: Share of vertex contacts whose incident face stays inside the reference face (measured:
#: ~0.92-0.97 on the pose families; the rest cross its boundary while still below it).
VERTEX_UNCLIPPED_SHARE_MIN = 0.9
#: Rounding (x the size) of one float64 operation chain over a few dozen terms.
ROUNDING_REL = 1e-12

_LABEL_FIELDS = (("colliding", "colliding"), ("axis", "axis"), ("depth", "depth"),
                 ("code", "contact_type_code"), ("feature_a", "feature_a"),
                 ("feature_b", "feature_b"))


def assert_labels_equal_exact(labels, exact, rows=slice(None)):
    for mine, theirs in _LABEL_FIELDS:
        np.testing.assert_array_equal(getattr(labels, mine), getattr(exact, theirs)[rows],
                                      err_msg=mine)
    np.testing.assert_array_equal(labels.normal.T, exact.normal[rows])


@pytest.mark.parametrize("seed", [0, pytest.param(7, marks=pytest.mark.slow)])
def test_batch_labels_equal_the_exact_solver_bit_for_bit_on_every_family(seed):
    p = family_poses(per_case=60 if seed == 0 else 600, seed=seed)
    inputs = prepare_inputs(*(p[k] for k in KEYS))
    exact = box_box_batch(*inputs)
    labels = label_block(lf.input_columns(inputs, 0, len(exact)))
    assert_labels_equal_exact(labels, exact)
    assert (~exact.colliding).any() and (exact.contact_type_code == 6).any()


@pytest.mark.parametrize("size_a, size_b", [([6.058, 2.438, 2.591], [12.0, 2.35, 0.8]),
                                            ([2.0, 2.0, 2.0], [2.0, 2.0, 2.0])])
def test_labels_from_unnormalised_inputs_equal_the_exact_solver(size_a, size_b):
    """The committee's path: pose_columns.Inputs (quaternions not normalised, sizes as one
    broadcast row) through input_block gives the exact solver's labels of the same call."""
    rows = generate_pairs(np.array(size_a), np.array(size_b), 3000, seed=5,
                          depth_fraction=(0.0, 0.01), progress=False)
    scaled = {k: rows[k] for k in KEYS}
    scaled["quaternion_a"] = rows["quaternion_a"] * 3.0  # not unit: normalised on the way
    scaled["size_a"], scaled["size_b"] = np.array(size_a), np.array(size_b)
    inputs = checked_inputs(*(scaled[k] for k in KEYS))
    exact = box_box_batch(*prepare_inputs(*(scaled[k] for k in KEYS)))
    for start, stop in ((0, 1000), (1000, 3000)):
        labels = label_block(input_block(inputs, start, stop))
        assert_labels_equal_exact(labels, exact, slice(start, stop))


def test_one_pair_labels_equal_the_scalar_exact_solver():
    p = family_poses(per_case=12, seed=3)
    for i in range(len(p["size_a"])):
        values = single_pair(*(p[k][i] for k in KEYS))
        colliding, axis, depth, normal, code, feature_a, feature_b, _, _ = label_one(values)
        exact = box_box_one(*values)
        assert (colliding, axis, depth, code, feature_a, feature_b) == (
            exact.colliding[0], exact.axis[0], exact.depth[0], exact.contact_type_code[0],
            exact.feature_a[0], exact.feature_b[0]), i
        assert normal == exact.normal[0].tolist(), i


def unclipped_errors(per_case: int, seed: int):
    """Exact answers, labels and the unclipped point's error (x the pair's size) on the pose
    families."""
    p = family_poses(per_case=per_case, seed=seed)
    inputs = prepare_inputs(*(p[k] for k in KEYS))
    exact = box_box_batch(*inputs)
    labels = label_block(lf.input_columns(inputs, 0, len(exact)))
    size = np.maximum(inputs[0].max(1), inputs[3].max(1))
    error = np.linalg.norm(labels.unclipped.T - exact.point, axis=1) / size
    return exact, labels, error


def test_unclipped_point_is_the_exact_point_where_nothing_is_clipped():
    """Edge-edge contacts never need clipping: their unclipped point is the exact point. A
    vertex contact needs it only where the incident edges leave the reference face while still
    below it (a few rows); tilted face contacts often (clamping is not clipping)."""
    exact, labels, error = unclipped_errors(per_case=60, seed=11)
    edges = exact.contact_type_code == 3
    vertex = np.isin(exact.contact_type_code, [1, 2])  # vertex-face, face-vertex
    assert edges.sum() > 100 and vertex.sum() > 100
    assert error[edges].max() < POINT_AGREEMENT_REL
    assert (error[vertex] < POINT_AGREEMENT_REL).mean() > VERTEX_UNCLIPPED_SHARE_MIN
    assert (error[exact.colliding] > CLIPPED_REL).any()  # clipped rows exist: not trivial


def test_aligned_boxes_overlapping_anywhere_give_the_exact_point():
    """A 20 ft container on a 40 ft container's roof, aligned, anywhere from fully inside to
    hanging over the end and the side: clamping the corners into the roof gives the
    intersection's corners, so the approximate point is the exact point."""
    rng = np.random.default_rng(4)
    n = 200
    offset = np.column_stack([rng.uniform(-8.5, 8.5, n), rng.uniform(-1.5, 1.5, n),
                              np.full(n, 2.591 - 0.001)])
    args = (np.array([12.192, 2.438, 2.591]), np.zeros(3), np.array([1.0, 0, 0, 0]),
            np.array([6.058, 2.0, 2.591]), offset, np.array([1.0, 0, 0, 0]))
    inputs = prepare_inputs(*args)
    exact = box_box_batch(*inputs)
    labels = label_block(lf.input_columns(inputs, 0, n))
    assert (exact.contact_type_code == 6).all()
    np.testing.assert_allclose(labels.unclipped.T, exact.point, atol=ROUNDING_REL * 12.192)
    assert labels.exact_point.all()  # aligned and fully touching: flagged exact


def test_one_pair_unclipped_point_equals_the_batch():
    p = family_poses(per_case=8, seed=13)
    inputs = prepare_inputs(*(p[k] for k in KEYS))
    labels = label_block(lf.input_columns(inputs, 0, len(inputs[0])))
    for i in range(len(p["size_a"])):
        values = [a[i].tolist() for a in inputs]
        exact, one = label_one(values)[7:]
        assert exact == labels.exact_point[i], i
        scale = max(values[0]) + max(values[3])
        np.testing.assert_allclose(one, labels.unclipped[:, i], rtol=0,
                                   atol=ROUNDING_REL * 40 * scale)


def test_rows_flagged_exact_have_the_exact_point():
    """``exact_point`` promises that the unclipped point is the exact solver's point: every
    edge-edge row and the face rows whose part below the reference face lies inside it."""
    exact, labels, error = unclipped_errors(per_case=120, seed=17)
    flagged = labels.exact_point
    assert not flagged[~exact.colliding].any()
    assert flagged[exact.contact_type_code == 3].all()
    face = exact.colliding & (exact.contact_type_code != 3)
    assert (flagged & face).sum() > 100 and (~flagged & face).sum() > 100  # both kinds occur
    assert error[flagged].max() < POINT_AGREEMENT_REL
