"""The committee's region classifier (the exact labeller) decides as the exact solver does.

Its unclipped point is the exact point only for edge-edge contacts and for parallel, aligned face
contacts with every incident vertex touching (``exact_point``): elsewhere the exact point is the
centre of pressure of the whole footprint (:mod:`impactnet.models.box.kernel_pressure`), and the
unclipped point (touching vertices clamped into the reference face) is the experts' baseline.
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.box.exact import box_box
from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL
from impactnet.models.compiled import PARALLEL_MIN_ROWS
from impactnet.models.geometry.poses import SIZE_FAMILIES
from impactnet.models.learned.region_label import label_block
from tests.models.box.test_exact_one import family_poses
from tests.models.helpers import KEYS, labelled_rows

#: Agreement (x the pair's size) of a point computed along two paths of float64 arithmetic.
POINT_AGREEMENT_REL = 1e-9
#: A point farther than this (x the size) from the exact one was changed by the clipping.
CLIPPED_REL = 1e-6
#: Share of vertex contacts whose vertex lies over the reference face, so that the unclipped
#: point is the manifold's single point (measured: 0.92 on the seeded pose families, as the
#: old rule's unclipped share; the rest touch past the face's rim and are clamped).
VERTEX_INSIDE_SHARE_MIN = 0.9
#: Share of those whose cut-off corner is a whole tetrahedron (the point d / 4 below the face;
#: measured: 0.96, the rest reach past the face's rim).
UNCLIPPED_CORNER_SHARE_MIN = 0.9
#: Depth of the aligned stacks (x the smaller box's shortest edge): shallow enough that the
#: face axis along which they were placed is the least overlap.
ALIGNED_DEPTH_REL = 1e-3
#: Rounding (x the size) of one float64 operation chain over a few dozen terms.
ROUNDING_REL = 1e-12

_LABEL_FIELDS = (("colliding", "colliding"), ("axis", "axis"),
                 ("code", "contact_type_code"), ("feature_a", "feature_a"),
                 ("feature_b", "feature_b"))


def assert_depth_is_the_exact_or_the_overlap(depth, exact_depth, code):
    """The labeller's depth is the SAT overlap: the exact solver's depth bit for bit, except on
    face contacts whose incident box hangs beyond the reference face, where the exact solver
    reports the shallower deepest point of the footprint (impactnet.models.box.kernels, stage 4)."""
    differs = depth != exact_depth
    assert not (differs & (code == 3)).any(), "edge-edge depths must be equal"
    assert (depth[differs] > exact_depth[differs]).all()


def assert_labels_equal_exact(labels, exact, rows=slice(None)):
    for mine, theirs in _LABEL_FIELDS:
        np.testing.assert_array_equal(getattr(labels, mine), getattr(exact, theirs)[rows],
                                      err_msg=mine)
    np.testing.assert_array_equal(labels.normal, exact.normal[rows])
    assert_depth_is_the_exact_or_the_overlap(labels.depth, exact.depth[rows], labels.code)


@pytest.mark.parametrize("seed", [0, pytest.param(7, marks=pytest.mark.slow)])
def test_batch_labels_equal_the_exact_solver_bit_for_bit_on_every_family(seed):
    p = family_poses(per_case=60 if seed == 0 else 600, seed=seed)
    inputs = tuple(p[k] for k in KEYS)
    exact = box_box(*inputs)
    labels = label_block(inputs)
    assert_labels_equal_exact(labels, exact)
    assert (~exact.colliding).any() and (exact.contact_type_code == 6).any()


@pytest.mark.parametrize("size_a, size_b", [([6.058, 2.438, 2.591], [12.0, 2.35, 0.8]),
                                            ([2.0, 2.0, 2.0], [2.0, 2.0, 2.0])])
def test_labels_from_unnormalised_inputs_equal_the_exact_solver(size_a, size_b):
    """The predictors' inputs: quaternions not normalised, sizes as one broadcast row; serial
    and parallel batches alike give the exact solver's labels of the same call."""
    rows = labelled_rows(size_a, size_b, 3000, 5)  # depths 0-0.01 of the shortest edge
    scaled = {k: rows[k] for k in KEYS}
    scaled["quaternion_a"] = rows["quaternion_a"] * 3.0  # not unit: normalised on the way
    scaled["size_a"], scaled["size_b"] = np.array(size_a), np.array(size_b)
    exact = box_box(*(scaled[k] for k in KEYS))
    for start, stop in ((0, PARALLEL_MIN_ROWS - 1), (1000, 3000)):
        labels = label_block(tuple(scaled[k] if k.startswith("size") else scaled[k][start:stop]
                                   for k in KEYS))
        assert_labels_equal_exact(labels, exact, slice(start, stop))


def test_one_pair_labels_equal_its_row_of_the_batch_bit_for_bit():
    p = family_poses(per_case=12, seed=3)
    batch = label_block(tuple(p[k] for k in KEYS))
    for i in range(0, len(p["size_a"]), 7):
        one = label_block(tuple(p[k][i] for k in KEYS))
        for name, value in one._asdict().items():
            np.testing.assert_array_equal(value[0], getattr(batch, name)[i], err_msg=name)


def unclipped_errors(per_case: int, seed: int):
    """Exact answers, labels, the unclipped point's error (x the pair's size) and the size (the
    larger box's largest edge, metres) on the pose families."""
    p = family_poses(per_case=per_case, seed=seed)
    inputs = tuple(p[k] for k in KEYS)
    exact = box_box(*inputs)
    labels = label_block(inputs)
    size = np.maximum(inputs[0].max(1), inputs[3].max(1))
    error = np.linalg.norm(labels.unclipped - exact.point, axis=1) / size
    return exact, labels, error, size


def test_edge_edge_unclipped_point_is_exact_and_a_vertex_contact_gives_its_vertex():
    """Edge-edge contacts: the unclipped point is the exact point. A vertex contact: it is the
    vertex on the mid-surface (the manifold's single point, d / 2 below the face) where the
    vertex lies over the face: a baseline, not the centre of pressure of the cut-off corner
    (d / 4 below the face where the corner's tetrahedron is not clipped), so such rows are
    not flagged."""
    exact, labels, error, size = unclipped_errors(per_case=60, seed=11)
    edges = exact.contact_type_code == 3
    vertex = np.isin(exact.contact_type_code, [1, 2])  # vertex-face, face-vertex
    assert edges.sum() > 100 and vertex.sum() > 100
    assert error[edges].max() < POINT_AGREEMENT_REL
    to_vertex = np.linalg.norm(labels.unclipped - exact.manifold_points[:, 0], axis=1)
    on_vertex = vertex & (to_vertex < POINT_AGREEMENT_REL * size)
    assert on_vertex.sum() > VERTEX_INSIDE_SHARE_MIN * vertex.sum()
    gap = np.abs(((labels.unclipped - exact.point) * exact.normal).sum(axis=1))
    quarter = np.abs(gap - exact.depth / 4) <= (POINT_AGREEMENT_REL + PRESSURE_FLOOR_REL) * size
    assert quarter[on_vertex].mean() > UNCLIPPED_CORNER_SHARE_MIN, quarter[on_vertex].mean()
    assert not labels.exact_point[vertex].any()
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
    exact = box_box(*args)
    labels = label_block(args)
    assert (exact.contact_type_code == 6).all()
    np.testing.assert_allclose(labels.unclipped, exact.point, atol=ROUNDING_REL * 12.192)
    assert labels.exact_point.all()  # aligned and fully touching: flagged exact


def aligned_stacks(n: int, seed: int) -> dict:
    """n pairs of the family sizes placed face to face, aligned (B turned by one of the 24
    rotations of the cube group), overlapping anywhere from fully inside to overhanging,
    ALIGNED_DEPTH_REL deep; the pair then turned and moved as a whole."""
    rng = np.random.default_rng(seed)
    sizes = np.array([SIZE_FAMILIES[name] for name in sorted(SIZE_FAMILIES)])
    pick = sizes[rng.integers(len(sizes), size=n)]
    size_a, size_b = pick[:, 0], pick[:, 1]
    turn = Rotation.create_group("O")[rng.integers(24, size=n)]
    reach = 0.5 * size_a + 0.5 * np.abs(np.einsum("nij,nj->ni", turn.as_matrix(), size_b))
    offset = rng.uniform(-0.9, 0.9, (n, 3)) * reach
    axis = rng.integers(3, size=n)
    depth = ALIGNED_DEPTH_REL * np.minimum(size_a.min(1), size_b.min(1))
    offset[np.arange(n), axis] = rng.choice([-1.0, 1.0], n) * (reach[np.arange(n), axis] - depth)
    world = Rotation.random(n, random_state=seed)
    position_a = rng.normal(size=(n, 3)) * 10.0
    return {"size_a": size_a, "position_a": position_a,
            "quaternion_a": world.as_quat(scalar_first=True), "size_b": size_b,
            "position_b": position_a + world.apply(offset),
            "quaternion_b": (world * turn).as_quat(scalar_first=True)}


def test_rows_flagged_exact_have_the_exact_point():
    """``exact_point`` promises that the unclipped point is the exact solver's point: every
    edge-edge row and the parallel, aligned face rows with every incident vertex touching
    (the aligned stacks, wherever they overhang), and no other face row."""
    p = family_poses(per_case=120, seed=17)
    stacks = aligned_stacks(600, seed=17)
    p = {k: np.concatenate([p[k], stacks[k]]) for k in KEYS}
    inputs = tuple(p[k] for k in KEYS)
    exact = box_box(*inputs)
    labels = label_block(inputs)
    size = np.maximum(inputs[0].max(1), inputs[3].max(1))
    error = np.linalg.norm(labels.unclipped - exact.point, axis=1) / size
    flagged, stacked = labels.exact_point, np.arange(len(exact)) >= len(exact) - 600
    assert not flagged[~exact.colliding].any()
    assert flagged[exact.contact_type_code == 3].all()
    face = exact.colliding & (exact.contact_type_code != 3)
    assert (exact.contact_type_code[stacked] == 6).all()  # impactnet.models.contacts.FACE_FACE
    np.testing.assert_array_equal(flagged[face], stacked[face])
    assert (~flagged & face).sum() > 100  # tilted face rows: not flagged
    assert error[flagged].max() < POINT_AGREEMENT_REL
