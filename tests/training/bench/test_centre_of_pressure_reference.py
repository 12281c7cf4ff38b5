"""The grid centre-of-pressure reference, and the exact solver's closed-form point against it.

The reference (``tests/training/bench/cop_reference.py``) shares no code with the solver's manifold
and clipping. It is checked on contacts with a known answer (a flat stack: the footprint's centroid
at half the depth; a landing edge: a third of the depth; a landing vertex: a quarter), for the
symmetry of swapping A and B, and for its own convergence, which justifies the tolerance of the
comparison with ``impactnet.models.box.exact.box_box(...).point`` on random face contacts of every
type (vertex-face, edge-face, face-face).
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from impactnet.models.box.exact import box_box
from impactnet.models.geometry.poses import SIZE_FAMILIES, first_contact_poses
from tests.training.bench.cop_reference import centre_of_pressure
from tests.training.bench.mujoco_reference import pose_args

SEED = 1123
#: Grid of the comparison with the closed form (cells a side, lattice points of edge cells),
#: and the finer grid that checks its convergence.
GRID, FINE_GRID = (64, 55), (128, 89)
#: Tolerance of the closed-form comparison, per row: the smaller of POINT_TOL_FOOTPRINT x the
#: footprint's longer side and POINT_TOL_EDGE x the pair's shortest edge (metres). Each is
#: twice the worst error of the GRID reference measured against a 384 / 89 grid (7e-4 of the
#: footprint, 3.1e-4 of the edge; cop_reference's table), and test_grid_converges_* checks
#: half of it on every row here. 2 mm on a 2 m cube: the 6.7 mm jump of docs/design.md's "one
#: incident face alone" rule, or a vertex mean (percents), would fail it.
POINT_TOL_FOOTPRINT, POINT_TOL_EDGE = 2e-3, 1e-3
#: Analytic cases: relative error allowed (x push depth, metres). The midpoint rule is exact on
#: the linear pieces; the kinks of the depth profile (the ridge of a landing edge or vertex)
#: cost ~ (depth / G)^2 relative to the depth.
ANALYTIC_TOL_REL = 1e-3
#: Rows per orientation family (uniform, near-parallel faces, near-parallel edges), and the
#: rows of each family re-solved on the fine grid.
ROWS, CONVERGENCE_ROWS = 300, 60
#: At least this many rows of each face contact kind (by the incident feature).
MIN_PER_KIND = 20
_FAMILIES = ("uniform", "near_parallel_faces", "near_parallel_edges")
_KIND = {"vertex-face": "vertex", "face-vertex": "vertex", "edge-face": "edge",
         "face-edge": "edge", "face-face": "face"}


def _pose(size_b, position_b, rotation_b, size_a=(2.0, 2.0, 2.0)):
    """One pair as the six argument arrays: A axis-aligned at the origin."""
    return pose_args({"size_a": [size_a], "position_a": [[0.0, 0, 0]],
                      "quaternion_a": [[1.0, 0, 0, 0]], "size_b": [size_b],
                      "position_b": [position_b],
                      "quaternion_b": [rotation_b.as_quat(scalar_first=True)]})


def _cop(args, normal, grid=(32, 21)):
    return centre_of_pressure(*args, np.atleast_2d(normal), grid=grid[0], refine=grid[1])


# ------------------------------------------------------------------ analytic cases


@pytest.mark.parametrize("below", [False, True])
def test_flat_stack_point_is_the_clipped_footprint_centroid_at_half_depth(below):
    """B (2 m) offset by (0.5, -0.3) and 10 mm into A's top (or bottom) face: the footprint is
    x in [-0.5, 1], y in [-1, 0.7]; its centroid is (0.25, -0.15), 5 mm below the face."""
    z = -1.99 if below else 1.99
    args = _pose([2.0, 2, 2], [0.5, -0.3, z], Rotation.identity())
    got = _cop(args, [0.0, 0, np.sign(z)])
    np.testing.assert_allclose(got.point[0], [0.25, -0.15, np.sign(z) * 0.995], atol=1e-12)
    assert not got.ref_is_b[0]


def test_yawed_flat_stack_point_is_on_the_axis():
    """A 45 deg yawed cube centred on A's face: the octagon's centroid, by symmetry."""
    args = _pose([2.0, 2, 2], [0.0, 0, 1.99], Rotation.from_euler("z", 45, degrees=True))
    np.testing.assert_allclose(_cop(args, [0.0, 0, 1]).point[0], [0, 0, 0.995], atol=1e-12)


def test_landing_edge_point_is_a_third_of_the_depth_below_the_face():
    """B turned 45 deg about x lands its lowest edge (along x) 10 mm deep at y = 0.1: the
    depth profile is a tent of half-width 10 mm, so the point is depth / 3 below A's face,
    at the middle of the edge's part over A (x in [-0.8, 1]: 0.1)."""
    depth, half_diagonal = 0.01, np.sqrt(2.0)
    args = _pose([2.0, 2, 2], [0.2, 0.1, 1.0 + half_diagonal - depth],
                 Rotation.from_euler("x", 45, degrees=True))
    got = _cop(args, [0.0, 0, 1])
    np.testing.assert_allclose(got.point[0], [0.1, 0.1, 1.0 - depth / 3.0],
                               atol=ANALYTIC_TOL_REL * depth)


def test_landing_vertex_point_is_a_quarter_of_the_depth_below_the_face():
    """B with a body diagonal vertical lands its lowest vertex 10 mm deep at (0.3, -0.2): the
    depth is a three-sided pyramid, so the point lies over the vertex, depth / 4 deep."""
    depth = 0.01
    rotation, _ = Rotation.align_vectors([[0.0, 0, -1]], [[-1.0, -1, -1]])
    vertex = rotation.apply([-1.0, -1, -1])
    args = _pose([2.0, 2, 2], np.array([0.3, -0.2, 1.0 - depth]) - vertex, rotation)
    np.testing.assert_allclose(_cop(args, [0.0, 0, 1]).point[0],
                               [0.3, -0.2, 1.0 - depth / 4.0], atol=ANALYTIC_TOL_REL * depth)


def test_swapping_a_and_b_keeps_the_point():
    """The reference face is the same physical face after the swap (B's with -normal)."""
    poses = first_contact_poses(200, (2, 2, 2), (1.5, 1.0, 0.7), rng=SEED,
                                depth_fraction=(1e-3, 0.01), orientation="near_parallel_faces")
    args = pose_args(poses)
    normal = box_box(*args).normal
    swapped = args[3:] + args[:3]
    np.testing.assert_allclose(_cop(swapped, -normal).point, _cop(args, normal).point,
                               atol=1e-9)


# ------------------------------------------------------------------ the closed form


@pytest.fixture(scope="module", params=["cube", pytest.param("container20_40",
                                                             marks=pytest.mark.slow)])
def face_contacts(request):
    """First contacts of every orientation family, the rows where the solver answers a face
    axis, with the grid reference on the face best aligned with the solver's normal."""
    size_a, size_b = SIZE_FAMILIES[request.param]
    parts = [first_contact_poses(ROWS, size_a, size_b, rng=SEED + k,
                                 depth_fraction=(1e-4, 0.01), orientation=family)
             for k, family in enumerate(_FAMILIES)]
    args = pose_args({key: np.concatenate([p[key] for p in parts]) for key in parts[0]})
    ours = box_box(*args)
    rows = np.flatnonzero(ours.colliding & (ours.contact_type != "edge-edge"))
    args = tuple(a[rows] for a in args)
    family = np.repeat(np.arange(len(_FAMILIES)), ROWS)[rows]
    reference = _cop(args, ours.normal[rows], GRID)
    scale = np.minimum(args[0].min(axis=1), args[3].min(axis=1))
    tolerance = np.minimum(POINT_TOL_FOOTPRINT * reference.footprint, POINT_TOL_EDGE * scale)
    return {"args": args, "point": ours.point[rows], "normal": ours.normal[rows],
            "kind": np.array([_KIND[t] for t in ours.contact_type[rows]]),
            "family": family, "reference": reference, "tolerance": tolerance}


def test_face_contacts_cover_every_kind(face_contacts):
    kinds, counts = np.unique(face_contacts["kind"], return_counts=True)
    assert set(kinds) == {"vertex", "edge", "face"} and counts.min() >= MIN_PER_KIND, counts


def test_grid_converges_to_half_the_tolerance(face_contacts):
    """The GRID reference is within half the tolerance of the FINE_GRID one on every row
    tried: the tolerance is at least twice the reference's own error."""
    take = np.concatenate([np.flatnonzero(face_contacts["family"] == k)[:CONVERGENCE_ROWS]
                           for k in range(len(_FAMILIES))])
    args = tuple(a[take] for a in face_contacts["args"])
    fine = _cop(args, face_contacts["normal"][take], FINE_GRID)
    gap = np.linalg.norm(face_contacts["reference"].point[take] - fine.point, axis=1)
    worst = int(np.argmax(gap / face_contacts["tolerance"][take]))
    assert (gap <= 0.5 * face_contacts["tolerance"][take]).all(), (
        take[worst], gap[worst], face_contacts["tolerance"][take[worst]])


@pytest.mark.parametrize("kind", ["vertex", "edge", "face"])
def test_closed_form_point_is_the_centre_of_pressure(face_contacts, kind):
    rows = face_contacts["kind"] == kind
    assert not face_contacts["reference"].empty[rows].any()
    gap = np.linalg.norm(face_contacts["point"] - face_contacts["reference"].point, axis=1)
    excess = np.where(rows, gap / face_contacts["tolerance"], 0.0)
    worst = int(np.argmax(excess))
    assert excess.max() <= 1.0, (
        f"{(excess > 1).sum()} of {rows.sum()} {kind} rows off; worst row {worst}: "
        f"{1e3 * gap[worst]:.3f} mm, tolerance {1e3 * face_contacts['tolerance'][worst]:.3f} "
        f"mm, family {_FAMILIES[face_contacts['family'][worst]]}")
