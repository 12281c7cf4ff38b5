"""Pose sweeps of one box resting on another, for the exact solver's continuity tests.

Not a test module. Every builder works on arrays (all poses of a sweep at once, so that a sweep
is one `box_box` call) and follows one frame convention:

* A sits at the origin with the identity orientation, so A's frame is the world frame and A's
  top face is the plane ``z = size_a[2] / 2`` with the outward normal ``+z``;
* B's orientation is ``tilt(axis, angle) * yaw(z, yaw) * base``: first a base orientation (the
  identity for a box lying flat, 45 degrees about x for a box standing on an edge, the body
  diagonal pointing down for one standing on a vertex), then a yaw about the vertical, then a
  tilt about a world axis;
* B's centre is at ``xy`` horizontally and at the height where B's lowest corner lies
  ``depth`` below A's top face (:func:`resting_poses`).

Keeping the depth while tilting. The last rule is how the depth stays fixed while B tilts: the
rotation is applied about B's centre and B is then shifted along A's normal by the change of its
lowest corner's height. A rotation about the centre plus that shift is a rotation about a pivot
on the contact; the deepest point of B stays exactly ``depth`` below A's face, so the overlap
along A's normal (A's face axis in the separating-axis test) is ``depth`` for every tilt. The
lowest corner's height is ``-sum_j h_j |R_2j|`` (the same support formula the solver uses).

Quaternions come from axis and angle (``[cos(a/2), sin(a/2) axis]``) and are composed with
:func:`impactnet.models.geometry.rotations.quaternion_multiply`; matrices come only from
:func:`impactnet.models.geometry.rotations.quaternion_to_matrix`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models.geometry.poses import SIZE_FAMILIES
from impactnet.models.geometry.rotations import quaternion_multiply, quaternion_to_matrix
from tests.models.helpers import KEYS

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
VERTICAL = np.array([0.0, 0.0, 1.0])
CUBE = SIZE_FAMILIES["cube"][0]  # 2 m cube
C20 = SIZE_FAMILIES["container20"][0]  # ISO 20 ft container
C40 = SIZE_FAMILIES["container40"][0]  # ISO 40 ft container
SLAB = SIZE_FAMILIES["slab"][0]  # 4 x 4 x 0.05 m
NEEDLE = SIZE_FAMILIES["needle"][0]  # 3 x 0.01 x 0.01 m
SPREADER = (12.0, 2.35, 0.8)  # the README's spreader (metres)

#: Stacks as (size of A, below; size of B, resting on A's top face), metres.
STACKS = {
    "cube_on_cube": (CUBE, CUBE),
    "c20_on_c40": (C40, C20),
    "c40_on_c40": (C40, C40),
    "needle_on_slab": (SLAB, NEEDLE),
    "spreader_on_c40": (C40, SPREADER),
}


class Sweep(NamedTuple):
    """n poses of a sweep and what the bounds of the tests need.

    Attributes
    ----------
    poses : dict of str to ndarray
        The six `box_box` inputs (:data:`tests.models.helpers.KEYS`), each (n, 3) or (n, 4).
    param : ndarray, shape (n,)
        The swept parameter (radians for yaw and tilt, metres for shift and depth).
    depth : ndarray, shape (n,)
        Depth of B's lowest corner below A's top face (metres).
    scale : float
        L (metres): the larger body's largest edge, unless the builder says otherwise.
    """

    poses: dict
    param: np.ndarray
    depth: np.ndarray
    scale: float


def axis_angle_quaternions(axis, angle) -> np.ndarray:
    """Quaternions (n, 4) of rotations by ``angle`` (n,) radians about unit ``axis`` (n, 3)."""
    axis, angle = np.atleast_2d(axis), np.atleast_1d(np.asarray(angle, float))
    half = 0.5 * angle
    return np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * axis], axis=1)


def random_axes(rng, n, horizontal=False) -> np.ndarray:
    """n unit axes (n, 3): uniform on the sphere, or uniform on the horizontal circle."""
    v = rng.standard_normal((n, 3))
    if horizontal:
        v[:, 2] = 0.0
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def edge_down_base() -> np.ndarray:
    """B turned 45 degrees about x: it stands on the bottom edge along x (quaternion (4,))."""
    return axis_angle_quaternions([1.0, 0.0, 0.0], np.pi / 4)[0]


def vertex_down_base() -> np.ndarray:
    """B turned so that its body diagonal points down: it stands on its (-,-,-) vertex."""
    diagonal = -np.ones(3) / np.sqrt(3.0)
    axis = np.cross(diagonal, -VERTICAL)
    angle = np.arctan2(np.linalg.norm(axis), diagonal @ -VERTICAL)
    return axis_angle_quaternions(axis / np.linalg.norm(axis), angle)[0]


def lowest_corner_offset(size_b, quaternion_b) -> np.ndarray:
    """Height of B's lowest corner above its centre (<= 0), shape (n,), metres."""
    rot = quaternion_to_matrix(quaternion_b)
    return -(0.5 * np.asarray(size_b) * np.abs(rot[:, 2, :])).sum(axis=1)


def resting_poses(size_a, size_b, depth, xy=(0.0, 0.0), yaw=0.0, tilt=0.0, axis=VERTICAL,
                  base=IDENTITY) -> dict:
    """Poses of B resting on A's top face with its lowest corner ``depth`` deep.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,)
        Full edge lengths (metres).
    depth : array_like, shape () or (n,)
        Depth of B's lowest corner below A's top face (metres, >= 0).
    xy : array_like, shape (2,) or (n, 2)
        B's centre, horizontally (metres).
    yaw, tilt : array_like, shape () or (n,)
        Radians: the yaw about the vertical, then the tilt about ``axis``.
    axis : array_like, shape (3,) or (n, 3)
        Unit tilt axis (world frame).
    base : array_like, shape (4,) or (n, 4)
        B's orientation before the yaw and the tilt.

    Returns
    -------
    dict of str to ndarray
        The six `box_box` inputs, n rows each.
    """
    depth, yaw, tilt = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float))
                                             for v in (depth, yaw, tilt)))
    xy = np.atleast_2d(np.asarray(xy, float))
    axis, base = np.atleast_2d(np.asarray(axis, float)), np.atleast_2d(np.asarray(base, float))
    n = max(len(depth), len(xy), len(axis), len(base))
    quaternion = quaternion_multiply(
        axis_angle_quaternions(np.broadcast_to(axis, (n, 3)), np.broadcast_to(tilt, (n,))),
        quaternion_multiply(axis_angle_quaternions(VERTICAL, np.broadcast_to(yaw, (n,))),
                            np.broadcast_to(base, (n, 4))))
    height = 0.5 * size_a[2] - np.broadcast_to(depth, (n,)) - lowest_corner_offset(size_b,
                                                                                   quaternion)
    position = np.column_stack([np.broadcast_to(xy, (n, 2)), height])
    values = (size_a, np.zeros(3), IDENTITY, size_b, position, quaternion)
    rows = (np.atleast_2d(np.asarray(v, float)) for v in values)
    return {key: np.broadcast_to(v, (n, v.shape[1])).copy() for key, v in zip(KEYS, rows)}


def sweep(size_a, size_b, kind, values, depth, xy=(0.0, 0.0), yaw=0.0, tilt=0.0,
          axis=VERTICAL, base=IDENTITY, direction=(1.0, 0.0)) -> Sweep:
    """One sweep of B resting on A: ``kind`` names the argument that ``values`` replaces.

    ``kind`` is ``"yaw"`` or ``"tilt"`` (radians), ``"depth"`` (metres) or ``"shift"``
    (metres along the horizontal unit ``direction`` from ``xy``); the other arguments are as
    in :func:`resting_poses` and stay fixed.
    """
    values = np.asarray(values, float)
    pose = dict(depth=depth, xy=xy, yaw=yaw, tilt=tilt, axis=axis, base=base)
    if kind == "shift":
        pose["xy"] = np.asarray(xy, float) + values[:, None] * np.asarray(direction, float)
    else:
        pose[kind] = values
    poses = resting_poses(size_a, size_b, **pose)
    n = len(poses["size_a"])
    return Sweep(poses, values, np.broadcast_to(np.asarray(pose["depth"], float), (n,)).copy(),
                 float(max(max(size_a), max(size_b))))


def concatenate(sweeps) -> dict:
    """The poses of several sweeps as one batch (rows in order)."""
    return {key: np.concatenate([s.poses[key] for s in sweeps]) for key in KEYS}


def take(poses: dict, index) -> dict:
    """Rows ``index`` of a batch of poses."""
    return {key: value[index] for key, value in poses.items()}


def steps(points: np.ndarray) -> np.ndarray:
    """Distances (n - 1,) between neighbouring rows of points (n, 3), metres."""
    return np.linalg.norm(np.diff(points, axis=0), axis=1)


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (n,) between rows of a and b (n, 3), ``atan2(|a x b|, a . b)``, radians (exact
    also near 0, where ``arccos`` loses half the digits)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), (a * b).sum(axis=1))


def depth_range(size_b) -> tuple:
    """Depths of the random sweeps (metres): 0.1 mm to 20 mm, at most half B's thinnest edge."""
    return 1e-4, min(0.02, 0.5 * min(size_b))


def lowest_corner_xy(poses) -> np.ndarray:
    """Horizontal position (n, 2) of B's lowest corner, metres."""
    rot = quaternion_to_matrix(poses["quaternion_b"])
    signs = -np.sign(rot[:, 2, :])  # the corner whose every axis points down
    signs[signs == 0] = 1.0
    local = 0.5 * poses["size_b"] * signs
    return (poses["position_b"] + np.einsum("nij,nj->ni", rot, local))[:, :2]


def corner_inside(poses, size_a, margin) -> bool:
    """True where B's lowest corner lies over A's top face, at least ``margin`` (m) inside."""
    inside = np.abs(lowest_corner_xy(poses)) <= 0.5 * np.asarray(size_a[:2]) - margin
    return bool(inside.all())


def random_sweeps(size_a, size_b, kind, rng, count, n) -> list:
    """``count`` seeded sweeps of ``n`` poses each of B resting on A, swept by ``kind``.

    Base poses: depth d log-uniform in :func:`depth_range`; yaw near-aligned (|yaw| <= 0.05)
    or uniform, half each; B's centre uniform within 0.8 of A's half-extents (B overhangs
    where its size and yaw make it).

    ``"yaw"`` turns B by 0.2 rad about the vertical and ``"shift"`` moves its centre on a
    straight line between two random points of that region, at a base tilt about a random
    horizontal axis of at most 0.01 d / L (the stacking regime of issue #11: a face contact
    however B overhangs). ``"tilt"`` turns B from level to min(0.3, 6 d / l) rad (l: B's
    shorter bottom edge) about a random axis (unit or horizontal, half each), past
    face-face, edge-face and vertex-face; ``"depth"`` runs the depth geometrically over
    :func:`depth_range` at a tilt of up to 2 d_max / l, so that the contact grows from a
    vertex to an edge to the face. For these two the pose is redrawn until B's lowest corner
    stays over A's face, 2 d_max inside its edges: a corner beyond A's edge makes the contact
    edge-edge, whose point is a crossing of two edges, not a centre of pressure (that change
    is tested on its own).
    """
    half = 0.5 * np.asarray(size_a[:2])
    short, scale = min(size_b[:2]), max(max(size_a), max(size_b))
    lo, hi = depth_range(size_b)
    out = []
    while len(out) < count:
        depth = np.exp(rng.uniform(np.log(lo), np.log(hi)))
        yaw = rng.uniform(-0.05, 0.05) if rng.random() < 0.5 else rng.uniform(-np.pi, np.pi)
        start, end = rng.uniform(-0.8, 0.8, (2, 2)) * half
        pose = dict(depth=depth, xy=start, yaw=yaw, axis=random_axes(rng, 1, True)[0],
                    tilt=rng.uniform(0.0, 0.01) * depth / scale)
        if kind == "yaw":
            values = yaw + np.linspace(0.0, 0.2, n)
        elif kind == "shift":
            length = np.linalg.norm(end - start)
            pose["direction"] = (end - start) / length
            values = np.linspace(0.0, length, n)
        elif kind == "tilt":
            pose["axis"] = random_axes(rng, 1, horizontal=rng.random() < 0.5)[0]
            values = np.linspace(0.0, min(0.3, 6.0 * depth / short), n)
        else:
            pose["tilt"] = rng.uniform(0.0, 2.0) * hi / short
            values = np.geomspace(lo, hi, n)
        made = sweep(size_a, size_b, kind, values, **pose)
        ends = take(made.poses, [1, -1])
        if kind in ("yaw", "shift") or corner_inside(ends, size_a, 2.0 * hi):
            out.append(made)
    return out


def yaw_sweep(size_a, size_b, position_b, yaws) -> Sweep:
    """B at a fixed ``position_b``, level, turned by ``yaws`` (n,) radians about the vertical
    (the README's sweeps, whose positions are given as such)."""
    yaws = np.asarray(yaws, float)
    n = len(yaws)
    poses = {"size_a": np.tile(size_a, (n, 1)), "position_a": np.zeros((n, 3)),
             "quaternion_a": np.tile(IDENTITY, (n, 1)), "size_b": np.tile(size_b, (n, 1)),
             "position_b": np.tile(position_b, (n, 1)),
             "quaternion_b": axis_angle_quaternions(VERTICAL, yaws)}
    depth = 0.5 * size_a[2] + 0.5 * size_b[2] - position_b[2]
    return Sweep(poses, yaws, np.full(n, depth), float(max(max(size_a), max(size_b))))


def tilted_stacks(size_a, size_b, rng, count, tilts, depth=None) -> Sweep:
    """``count`` random stacks, each at every tilt of ``tilts`` (k,): ``count * k`` rows,
    row ``i * k + j`` = stack i at tilt j (the issue #11 poses).

    Each stack: depth log-uniform in :func:`depth_range`; yaw near-aligned or uniform, half
    each; B's centre uniform within 0.8 of A's half-extents (overhang where B is long); tilt
    axis uniform on the sphere for even stacks, on the horizontal circle for odd ones; a given
    ``depth`` (metres) replaces the random ones. The swept parameter is the tilt; ``scale`` is
    the longer edge of the two touching faces.
    """
    lo, hi = depth_range(size_b)
    k = len(tilts)
    drawn = np.exp(rng.uniform(np.log(lo), np.log(hi), count))
    depth = np.repeat(drawn if depth is None else np.full(count, depth), k)
    near = rng.random(count) < 0.5
    yaw = np.repeat(np.where(near, rng.uniform(-0.05, 0.05, count),
                             rng.uniform(-np.pi, np.pi, count)), k)
    xy = np.repeat(rng.uniform(-0.8, 0.8, (count, 2)) * 0.5 * np.asarray(size_a[:2]), k, 0)
    axes = np.where((np.arange(count) % 2 == 0)[:, None], random_axes(rng, count),
                    random_axes(rng, count, horizontal=True))
    tilt = np.tile(np.asarray(tilts, float), count)
    poses = resting_poses(size_a, size_b, depth, xy, yaw, tilt, np.repeat(axes, k, 0))
    return Sweep(poses, tilt, depth, float(max(max(size_a[:2]), max(size_b[:2]))))


def vertex_slide(yaws, depth, n) -> Sweep:
    """2 m cube standing on its vertex ``depth`` deep on another one's top face, slid in x
    across the top edge x = 1 (vertex from ``1 - 4 depth`` to ``1 + 4 depth``, at y = 0.2),
    once per yaw: the contact changes from face-vertex to edge-edge, then separates."""
    shift = np.linspace(1.0 - 4.0 * depth, 1.0 + 4.0 * depth, n)
    made = [sweep(CUBE, CUBE, "shift", shift, depth, xy=(0.0, 0.2), yaw=yaw,
                  base=vertex_down_base()) for yaw in yaws]
    return Sweep(concatenate(made), np.tile(shift, len(yaws)), np.full(n * len(yaws), depth),
                 2.0)


def edge_down_sweep(delta, depth) -> Sweep:
    """2 m cube standing on its bottom edge along x, ``depth`` deep in another one's top face
    at (0.1, 0.2), turned by 45 degrees + ``delta`` (n,) about x through its centre."""
    return sweep(CUBE, CUBE, "tilt", delta, depth, xy=(0.1, 0.2), axis=(1.0, 0.0, 0.0),
                 base=edge_down_base())


def vertex_down_sweep(axes, delta, depth) -> Sweep:
    """2 m cube standing on its vertex ``depth`` deep in another one's top face at (0.1, 0.2),
    turned by ``delta`` (n,) about each unit axis of ``axes`` (k, 3): k n rows, axis-major."""
    made = [sweep(CUBE, CUBE, "tilt", delta, depth, xy=(0.1, 0.2), axis=axis,
                  base=vertex_down_base()) for axis in axes]
    return Sweep(concatenate(made), np.tile(delta, len(axes)), np.concatenate(
        [m.depth for m in made]), 2.0)
