"""Pose recipes for the comparisons with MuJoCo: stacking, and edge-on-edge contacts.

* :func:`stacking_poses` (issue #11 item 3): B rests on A's top face. A sits at the origin,
  axis-aligned; B's centre is offset uniformly by up to ``offset_fraction`` of A's length and
  width in x and y, B is turned by a uniform yaw, then tilted by ``tilt`` about a uniformly
  random horizontal axis, and lowered until its deepest point is ``push`` below A's top face,
  ``push`` uniform in ``push_range``.
* :func:`edge_edge_poses` (issue #11 item 4): two boxes touching edge on edge. A is turned about
  its x axis by ``alpha`` (so that its edge along x, at +y and +z, is the highest), B about its
  x axis by ``beta`` and upside down (its edge along x is the lowest), then B is yawed by the
  crossing angle; the two edges cross at points drawn in the middle of both edges, B is pushed
  down by ``push`` and the whole pair is given a uniform random world rotation. With the edges
  horizontal, their common normal is vertical: the contact normal is A's edge x B's edge.

Both return the dict layout of :func:`impactnet.models.geometry.poses.first_contact_poses` (six pose
arrays, quaternions (w, x, y, z) with w >= 0, and ``push_depth``), plus their own parameters.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from impactnet.models.geometry.poses import SIZE_FAMILIES

#: Stacking tilts of the issue: 0 and 10^k rad for k = -12..-2.
STACKING_TILTS = (0.0,) + tuple(10.0 ** k for k in range(-12, -1))
#: Stacking pairs: name -> (size_a, size_b), full edge lengths (metres), B on top of A.
STACKING_FAMILIES = {
    "cube": (SIZE_FAMILIES["cube"][0], SIZE_FAMILIES["cube"][1]),
    "20ft on 40ft": (SIZE_FAMILIES["container40"][0], SIZE_FAMILIES["container20"][0]),
    "40ft on 40ft": SIZE_FAMILIES["container40"],
}
#: Stacking push range (metres): B's deepest point 0.1 to 20 mm below A's top face.
STACKING_PUSH_M = (1e-4, 0.02)
#: B's centre offset, as a fraction of A's length and width (x, y): +-0.5 m for 2 m cubes.
STACKING_OFFSET_FRACTION = 0.25
#: Edge-on-edge crossing angles (radians): log-uniform from ~1 deg (skewed) to 90 deg.
EDGE_CROSSING_RANGE = (np.radians(1.0), np.radians(90.0))
#: Turn of each box about its edge's axis (radians): the faces beside the edge stay 20 deg or
#: more away from the contact normal, so no face axis competes with the edge pair.
EDGE_TURN_RANGE = (np.radians(20.0), np.radians(70.0))
#: Edge-on-edge push, as a fraction of the pair's shortest edge (dimensionless): 1e-5 to 1e-3.
EDGE_PUSH_FRACTION = (1e-5, 1e-3)
#: Where the edges cross, as a fraction of each half-edge from its middle (dimensionless).
EDGE_CROSSING_SPAN = 0.6


def _quaternions(rotation: Rotation) -> np.ndarray:
    """(n, 4) (w, x, y, z) with w >= 0."""
    q = rotation.as_quat(scalar_first=True)
    return np.where(q[:, :1] < 0.0, -q, q)


def _sizes(size, n):
    return np.broadcast_to(np.asarray(size, dtype=np.float64), (n, 3)).copy()


def stacking_poses(n, size_a, size_b, tilt, rng, offset_fraction=STACKING_OFFSET_FRACTION,
                   push_range=STACKING_PUSH_M) -> dict:
    """B resting on A's top face with a tilt (see the module docstring).

    Parameters
    ----------
    n : int
        Number of pairs.
    size_a, size_b : array_like, shape (3,)
        Full edge lengths (metres); A is the lower box.
    tilt : float
        Tilt of B about a random horizontal axis (radians), >= 0.
    rng : numpy.random.Generator or int
    offset_fraction : float, optional
        Largest |x|, |y| offset of B's centre as a fraction of A's x, y sizes.
    push_range : (float, float), optional
        Depth of B's deepest point below A's top face (metres).

    Returns
    -------
    dict of ndarray
        The six pose arrays (n, 3) / (n, 4), ``push_depth`` (n,) metres, ``tilt`` (n,) rad.
    """
    rng = np.random.default_rng(rng)
    size_a, size_b = _sizes(size_a, n), _sizes(size_b, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    axis = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)])
    rotation = Rotation.from_rotvec(tilt * axis) * Rotation.from_euler("z", yaw[:, None])
    push = rng.uniform(*push_range, n)
    offset = rng.uniform(-1.0, 1.0, (n, 2)) * offset_fraction * size_a[:, :2]
    reach = 0.5 * np.einsum("nk,nk->n", np.abs(rotation.as_matrix()[:, 2, :]), size_b)
    position_b = np.column_stack([offset, 0.5 * size_a[:, 2] + reach - push])
    return {"size_a": size_a, "position_a": np.zeros((n, 3)),
            "quaternion_a": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), "size_b": size_b,
            "position_b": position_b, "quaternion_b": _quaternions(rotation),
            "push_depth": push, "tilt": np.full(n, float(tilt))}


def _top_edge(half, turn):
    """Middle (n, 3) of a box's highest edge along x after turning it by ``turn`` about x."""
    y = half[:, 1] * np.cos(turn) - half[:, 2] * np.sin(turn)
    z = half[:, 1] * np.sin(turn) + half[:, 2] * np.cos(turn)
    return np.column_stack([np.zeros(len(turn)), y, z])


def edge_edge_poses(n, size_a, size_b, rng, crossing=None, push_fraction=EDGE_PUSH_FRACTION,
                    turn_range=EDGE_TURN_RANGE) -> dict:
    """Two boxes touching edge on edge, pushed in slightly (see the module docstring).

    Parameters
    ----------
    n : int
    size_a, size_b : array_like, shape (3,)
        Full edge lengths (metres); the crossing edges are the boxes' x edges.
    rng : numpy.random.Generator or int
    crossing : float, optional
        Angle between the two edges (radians); default log-uniform in
        :data:`EDGE_CROSSING_RANGE`.
    push_fraction : (float, float), optional
        Push along the common normal, as a fraction of the pair's shortest edge.
    turn_range : (float, float), optional
        Turns of A and B about their edges (radians).

    Returns
    -------
    dict of ndarray
        The six pose arrays, ``push_depth`` (n,) metres, ``crossing`` (n,) rad and
        ``normal`` (n, 3), the contact normal from A towards B (world frame).
    """
    rng = np.random.default_rng(rng)
    size_a, size_b = _sizes(size_a, n), _sizes(size_b, n)
    if crossing is None:
        crossing = np.exp(rng.uniform(*np.log(EDGE_CROSSING_RANGE), n))
    crossing = np.broadcast_to(np.asarray(crossing, dtype=np.float64), (n,))
    alpha, beta = rng.uniform(*turn_range, (2, n))
    shortest = np.minimum(size_a.min(axis=1), size_b.min(axis=1))
    push = rng.uniform(*push_fraction, n) * shortest
    along_a, along_b = rng.uniform(-EDGE_CROSSING_SPAN, EDGE_CROSSING_SPAN, (2, n))
    rot_a = Rotation.from_euler("x", alpha[:, None])
    # B: its highest x edge after turning by beta, then flipped about x (lowest), then yawed.
    rot_b = Rotation.from_euler("z", crossing[:, None]) * Rotation.from_euler(
        "x", (np.pi + beta)[:, None])
    edge_a = _top_edge(0.5 * size_a, alpha) + np.column_stack(
        [along_a * 0.5 * size_a[:, 0], np.zeros((n, 2))])
    edge_b_local = _top_edge(0.5 * size_b, beta) * [1.0, -1.0, -1.0]  # flipped about x
    edge_b = Rotation.from_euler("z", crossing[:, None]).apply(edge_b_local)
    direction_b = np.column_stack([np.cos(crossing), np.sin(crossing), np.zeros(n)])
    cross_point = edge_a.copy()  # on A's edge; B's edge passes through it, pushed down
    position_b = cross_point - edge_b - (along_b * 0.5 * size_b[:, 0])[:, None] * direction_b
    position_b[:, 2] -= push
    world = Rotation.from_quat(rng.standard_normal((n, 4)))  # uniform on SO(3)
    return {"size_a": size_a, "position_a": np.zeros((n, 3)),
            "quaternion_a": _quaternions(world * rot_a), "size_b": size_b,
            "position_b": world.apply(position_b),
            "quaternion_b": _quaternions(world * rot_b), "push_depth": push,
            "crossing": crossing, "normal": world.apply(np.tile([0.0, 0.0, 1.0], (n, 1)))}
