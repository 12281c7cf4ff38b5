"""Exact solver against python-fcl's Box-Box (an independent implementation, ODE's dBoxBox).

FCL prefers face axes by a 5 % factor and culls manifolds to 4 points (see
tests/models/fcl_reference.py); the comparison is exact where those do not apply, and where
FCL picked another axis ours must be the shallower one.
"""
import numpy as np
import pytest

from models.exact import box_box
from tests.models.fcl_reference import fcl_box_box
from training.poses import ORIENTATIONS, SIZE_FAMILIES, first_contact_poses

#: FCL's axis-selection factor: an edge axis must be 5 % shallower to replace a face axis.
FCL_FUDGE = 1.05
#: Normal agreement where the least-penetration axis is unambiguous (degrees).
NORMAL_TOL_DEG = 1e-6
#: Relative depth agreement, and the absolute floor (x pair scale) for the shallowest pushes:
#: FCL pads its edge-axis radii by ~10 ulps, ours is exact to a few ulps.
DEPTH_RTOL, DEPTH_ATOL_REL = 1e-9, 1e-13
#: Single-point contact positions agree to this fraction of the pair scale.
POINT_TOL_REL = 1e-9
POSES_PER_CASE = 400  # 7 size families x 4 orientation families x 400 = 11,200 poses


def angle_deg(u, v):
    """Angle between unit vectors (degrees), accurate near 0 (arccos of a dot is not)."""
    return np.degrees(2 * np.arcsin(np.clip(0.5 * np.linalg.norm(u - v, axis=-1), 0, 1)))


def overlap_along(direction, poses):
    """Overlap (metres) of the two boxes along unit world directions, shape (n,)."""
    from models.rotations import quaternion_to_matrix

    radius = 0.0
    for side in ("a", "b"):
        rot = quaternion_to_matrix(poses[f"quaternion_{side}"])
        local = np.einsum("nij,ni->nj", rot, direction)
        radius = radius + 0.5 * (np.abs(local) * poses[f"size_{side}"]).sum(axis=1)
    centre = np.einsum("ni,ni->n", direction, poses["position_b"] - poses["position_a"])
    return radius - np.abs(centre)


def second_best_ratio(poses):
    """Second-smallest over smallest of the 15 SAT overlaps (axes counted by index), from
    `models.approach.axis_overlaps`, an implementation apart from the solver's."""
    from models.approach import axis_overlaps
    from models.rotations import quaternion_to_matrix

    rot_a = quaternion_to_matrix(poses["quaternion_a"])
    rot = np.swapaxes(rot_a, 1, 2) @ quaternion_to_matrix(poses["quaternion_b"])
    t = np.einsum("nij,ni->nj", rot_a, poses["position_b"] - poses["position_a"])
    over = axis_overlaps(poses["size_a"], poses["size_b"], rot, t)
    two = np.sort(over, axis=1)[:, :2]
    return two[:, 1] / two[:, 0]


@pytest.fixture(scope="module", params=sorted(SIZE_FAMILIES))
def family(request):
    size_a, size_b = SIZE_FAMILIES[request.param]
    chunks = [first_contact_poses(POSES_PER_CASE, size_a, size_b, rng=seed,
                                  depth_fraction=(1e-4, 0.01), orientation=orientation)
              for seed, orientation in enumerate(ORIENTATIONS)]
    poses = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    args = [poses[k] for k in ("size_a", "position_a", "quaternion_a",
                               "size_b", "position_b", "quaternion_b")]
    return poses, box_box(*args), fcl_box_box(*args)


def test_collision_flags_agree(family):
    poses, ours, theirs = family
    np.testing.assert_array_equal(ours.colliding, theirs.colliding)
    assert ours.colliding.all()


def test_normals_agree_where_the_axis_is_unambiguous(family):
    poses, ours, theirs = family
    clear = second_best_ratio(poses) > FCL_FUDGE * (1 + 1e-6)
    assert clear.mean() > 0.25
    angle = angle_deg(ours.normal, theirs.normal)[clear]
    assert angle.max() <= NORMAL_TOL_DEG, np.flatnonzero(clear)[np.argmax(angle)]


def test_where_fcl_picks_another_axis_ours_is_shallower(family):
    poses, ours, theirs = family
    scale = 0.5 * (poses["size_a"].max(1) + poses["size_b"].max(1))
    along_theirs = overlap_along(theirs.normal, poses)
    assert (ours.depth <= along_theirs + DEPTH_ATOL_REL * scale).all()


def test_depths_agree_where_the_normals_agree(family):
    poses, ours, theirs = family
    scale = 0.5 * (poses["size_a"].max(1) + poses["size_b"].max(1))
    same = angle_deg(ours.normal, theirs.normal) <= NORMAL_TOL_DEG
    deepest = ours.manifold_depths.max(axis=1)
    np.testing.assert_allclose(deepest[same], theirs.depth[same], rtol=DEPTH_RTOL,
                               atol=(DEPTH_ATOL_REL * scale[same]).max())
    # The SAT depth is the deepest manifold point unless the clip removed that vertex.
    assert (ours.depth >= deepest - DEPTH_ATOL_REL * scale).all()


def test_single_point_contacts_agree(family):
    poses, ours, theirs = family
    scale = 0.5 * (poses["size_a"].max(1) + poses["size_b"].max(1))
    same = angle_deg(ours.normal, theirs.normal) <= NORMAL_TOL_DEG
    single = same & (ours.manifold_count == 1) & np.array([len(d) == 1 for d in theirs.depths])
    assert single.sum() > 0.2 * len(single)
    error = np.linalg.norm(ours.point - theirs.point, axis=1) / scale
    assert error[single].max() <= POINT_TOL_REL
