"""Seeded sampler of box pairs at first contact, as a simulator sees them.

Stages (all vectorised over the n rows, float64):

1. Relative orientation ``R_ab`` (B's axes as columns in A's frame), by ``orientation``:
   ``"uniform"`` (Haar on SO(3), Shoemake's method), ``"near_parallel_faces"`` (one of the 24
   axis-aligned rotations times a small tilt), ``"near_parallel_edges"`` (axis-aligned, then a
   uniform spin about one of A's axes, then a small tilt about an axis perpendicular to it, so
   one edge direction of B is nearly parallel to one of A's) or ``"paper"`` (roll, pitch, yaw
   uniform in [-pi/2, pi/2], ``R = Rz(yaw) Ry(pitch) Rx(roll)``).
2. Approach direction ``d`` uniform on the unit sphere (A's frame); B is placed at the exact
   first-touch distance ``s*`` along ``d``
   (:func:`impactnet.models.geometry.approach.touching_distance`).
3. Push: B is moved in by ``depth = U(depth_fraction) * shortest edge of the pair`` (moved out
   by that amount for the separated share), so its centre is at ``(s* - push_depth) d``.
4. World pose: A gets a uniform random rotation and its centre at ``world_offset``; B moves
   rigidly with A.

The same generator state gives the same arrays, byte for byte.
"""
from __future__ import annotations

import itertools

import numpy as np

from impactnet.models.geometry.approach import touching_distance


def _rotation():
    """SciPy's ``Rotation``, imported on first use: sampling poses needs SciPy (the train
    extra), importing this module does not (serving never samples)."""
    from scipy.spatial.transform import Rotation

    return Rotation


#: Tilt angles of the near-parallel families are log-uniform in this range (radians).
TILT_RANGE = (1e-9, 1e-2)

#: Orientation families accepted by :func:`first_contact_poses`.
ORIENTATIONS = ("uniform", "near_parallel_faces", "near_parallel_edges", "paper")

_CUBE = (2.0, 2.0, 2.0)
_C20 = (6.058, 2.438, 2.591)  # ISO 20 ft container, metres
_C40 = (12.192, 2.438, 2.591)  # ISO 40 ft container, metres

#: name -> (size_a, size_b), full edge lengths in metres.
SIZE_FAMILIES = {
    "cube": (_CUBE, _CUBE),
    "container20": (_C20, _C20),
    "container20_40": (_C20, _C40),
    "container40": (_C40, _C40),
    "slab": ((4.0, 4.0, 0.05), (1.0, 1.0, 1.0)),  # aspect 80
    "needle": ((3.0, 0.01, 0.01), (1.0, 1.0, 1.0)),  # aspect 300
    "sheet": ((10.0, 10.0, 0.001), (1.0, 1.0, 1.0)),  # aspect 1e4
}


def _axis_aligned_rotations():
    """The 24 proper signed permutation matrices, shape (24, 3, 3)."""
    mats = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            m = np.zeros((3, 3))
            m[np.arange(3), perm] = signs
            if np.linalg.det(m) > 0:
                mats.append(m)
    return np.array(mats)


#: The 24 rotations that map the coordinate axes onto (signed) coordinate axes.
AXIS_ALIGNED_ROTATIONS = _axis_aligned_rotations()


def _unit_vectors(rng, n):
    """n directions uniform on the unit sphere, shape (n, 3)."""
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def shoemake_quaternions(rng, n):
    """n quaternions (w, x, y, z) uniform on SO(3) (Shoemake 1992), shape (n, 4)."""
    u1, u2, u3 = rng.random((3, n))
    a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
    t2, t3 = 2.0 * np.pi * u2, 2.0 * np.pi * u3
    return np.stack([b * np.cos(t3), a * np.sin(t2), a * np.cos(t2), b * np.sin(t3)], axis=1)


def _matrices(quaternion):
    return _rotation().from_quat(quaternion, scalar_first=True).as_matrix()


def _canonical_quaternions(matrix):
    """Rotation matrices (n, 3, 3) -> quaternions (w, x, y, z) with w >= 0, shape (n, 4)."""
    q = _rotation().from_matrix(matrix).as_quat(scalar_first=True)
    return np.where(q[:, :1] < 0.0, -q, q)


def _tilts(rng, n, axes=None):
    """Rotations by log-uniform angles in TILT_RANGE about given (or random) unit axes."""
    lo, hi = np.log(TILT_RANGE[0]), np.log(TILT_RANGE[1])
    angle = np.exp(rng.uniform(lo, hi, n))
    if axes is None:
        axes = _unit_vectors(rng, n)
    return _rotation().from_rotvec(angle[:, None] * axes).as_matrix()


def relative_rotations(rng, n, orientation="uniform"):
    """Relative orientations ``R_ab`` of a family (see the module docstring), shape (n, 3, 3)."""
    if orientation == "uniform":
        return _matrices(shoemake_quaternions(rng, n))
    if orientation == "near_parallel_faces":
        aligned = AXIS_ALIGNED_ROTATIONS[rng.integers(0, 24, n)]
        return _tilts(rng, n) @ aligned
    if orientation == "near_parallel_edges":
        aligned = AXIS_ALIGNED_ROTATIONS[rng.integers(0, 24, n)]
        k = rng.integers(0, 3, n)  # A's axis that one of B's edges stays (nearly) parallel to
        spin_axis = np.eye(3)[k]
        spin = _rotation().from_rotvec(rng.uniform(-np.pi, np.pi, n)[:, None] * spin_axis)
        phi = rng.uniform(0.0, 2.0 * np.pi, n)
        k1, k2 = (k + 1) % 3, (k + 2) % 3
        tilt_axis = np.cos(phi)[:, None] * np.eye(3)[k1] + np.sin(phi)[:, None] * np.eye(3)[k2]
        return _tilts(rng, n, tilt_axis) @ spin.as_matrix() @ aligned
    if orientation == "paper":
        roll, pitch, yaw = rng.uniform(-np.pi / 2, np.pi / 2, (3, n))
        # Extrinsic x, then y, then z: R = Rz(yaw) Ry(pitch) Rx(roll).
        return _rotation().from_euler("xyz", np.stack([roll, pitch, yaw], axis=1)).as_matrix()
    raise ValueError(f"orientation must be one of {ORIENTATIONS}, got {orientation!r}")


def first_contact_poses(n, size_a, size_b, rng, depth_fraction=(0.0, 0.01),
                        separated_share=0.0, orientation="uniform", world_offset=None):
    """Sample n box pairs at first contact, pushed in (or pulled out) by a small depth.

    Parameters
    ----------
    n : int
        Number of pairs.
    size_a, size_b : array_like, shape (3,) or (n, 3)
        Full edge lengths in metres.
    rng : numpy.random.Generator or int
        Random source (an int is used as the seed of ``default_rng``).
    depth_fraction : (float, float), optional
        Push depth range, as fractions of the shortest edge of the pair (dimensionless).
    separated_share : float, optional
        Share of rows (exactly ``round(share * n)``, at random positions) moved out instead
        of in, so that they are separated.
    orientation : str, optional
        Relative-orientation family, one of :data:`ORIENTATIONS`.
    world_offset : None, float or array_like of shape (3,) or (n, 3), optional
        World position of A's centre in metres (a float c means (c, c, c)); default 0.

    Returns
    -------
    dict of ndarray
        ``size_a``, ``size_b`` (n, 3) metres; ``position_a``, ``position_b`` (n, 3) world
        centres, metres; ``quaternion_a``, ``quaternion_b`` (n, 4) (w, x, y, z), w >= 0;
        ``direction`` (n, 3) unit approach direction in the world frame (B's centre is at
        ``position_a + (touch_distance - push_depth) * direction``); ``push_depth`` (n,)
        metres, > 0 pushed in, < 0 pulled out; ``touch_distance`` (n,) first-touch
        centre distance ``s*`` in metres; ``separated`` (n,) bool.
    """
    rng = np.random.default_rng(rng)
    size_a = np.broadcast_to(np.asarray(size_a, dtype=np.float64), (n, 3)).copy()
    size_b = np.broadcast_to(np.asarray(size_b, dtype=np.float64), (n, 3)).copy()
    offset = np.zeros(3) if world_offset is None else np.asarray(world_offset, np.float64)
    position_a = np.broadcast_to(offset, (n, 3)).copy()

    rotation_ab = relative_rotations(rng, n, orientation)
    direction_local = _unit_vectors(rng, n)
    touch = touching_distance(size_a, size_b, rotation_ab, direction_local)
    shortest = np.minimum(size_a.min(axis=1), size_b.min(axis=1))
    depth = rng.uniform(depth_fraction[0], depth_fraction[1], n) * shortest
    separated = rng.permutation(n) < int(round(separated_share * n))
    push = np.where(separated, -depth, depth)

    rotation_a = _matrices(shoemake_quaternions(rng, n))
    direction = np.einsum("nij,nj->ni", rotation_a, direction_local)
    position_b = position_a + (touch - push)[:, None] * direction
    return {
        "size_a": size_a,
        "position_a": position_a,
        "quaternion_a": _canonical_quaternions(rotation_a),
        "size_b": size_b,
        "position_b": position_b,
        "quaternion_b": _canonical_quaternions(rotation_a @ rotation_ab),
        "direction": direction,
        "push_depth": push,
        "touch_distance": touch,
        "separated": separated,
    }
