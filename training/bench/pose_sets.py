"""The benchmark's pose sets: first contacts of a scene, and the paper's Figure 2 hard case.

* :func:`scene_poses`: ``impactnet.models.geometry.poses.first_contact_poses`` for every pair of the
scene
  (uniform relative orientation, the scene's ``depth_fraction``), the same count per pair,
  interleaved so that any prefix covers every pair evenly (a subsample is a prefix).
* :func:`figure2_poses`: two cubes (the scene's ``cube`` body when it has one, else edge
  :data:`FIGURE2_EDGE_M`); A axis-aligned at the origin; B's bottom face tilted by ``tilt``
  about its own diagonal so that one vertex dips lowest, that vertex placed on A's top face at
  a random point of its middle half and pushed in by :data:`FIGURE2_DEPTH_FRACTION` of the
  edge; B also turned about the vertical by a random yaw so that its edges do not line up with
  A's mesh grid. Tilts are log-spaced from :data:`FIGURE2_TILT_MAX_RAD` (10 degrees) down to
  :data:`FIGURE2_TILT_MIN_RAD`. With the tilt well above ``depth / (sqrt(2) edge)`` the exact
  contact is vertex-face; below it the vertices next to the dipping one go under as well, and
  the contact becomes face-face with B's whole overlapping face sharing the load.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

#: Figure 2 tilts, radians: from 10 degrees down to 1e-6 rad, log-spaced.
FIGURE2_TILT_MAX_RAD = float(np.deg2rad(10.0))
FIGURE2_TILT_MIN_RAD = 1e-6
#: Push depth of B's dipping vertex, as a fraction of the cube edge (the middle of the default
#: scene's depth range, 0-1 %).
FIGURE2_DEPTH_FRACTION = 0.005
#: Cube edge (metres) when the scene has no ``cube`` body: the paper's cube.
FIGURE2_EDGE_M = 2.0
_POSE_KEYS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")


@dataclass
class PoseSet:
    """N box pairs in the solver's argument order, with what the report needs to know."""

    name: str  # "scene" or "figure2"
    size_a: np.ndarray  # (n, 3) full edge lengths, metres
    position_a: np.ndarray  # (n, 3) world centres, metres
    quaternion_a: np.ndarray  # (n, 4) (w, x, y, z)
    size_b: np.ndarray
    position_b: np.ndarray
    quaternion_b: np.ndarray
    pair: np.ndarray  # (n,) index of the scene pair ("figure2": the cube pair or -1)
    pair_names: tuple[tuple[str, str], ...]  # scene body names (a, b) per pair index
    tilt: np.ndarray | None = None  # (n,) Figure 2 tilt, radians; None for the scene set
    description: str = ""

    def __len__(self) -> int:
        return int(self.size_a.shape[0])

    @property
    def scale(self) -> np.ndarray:
        """(n,) the smaller body's shortest edge, metres (the point error's yardstick)."""
        return np.minimum(self.size_a.min(axis=1), self.size_b.min(axis=1))

    def args(self, rows=None) -> tuple[np.ndarray, ...]:
        """The six solver arguments, contiguous float64, of ``rows`` (a slice or index)."""
        rows = slice(None) if rows is None else rows
        return tuple(np.ascontiguousarray(getattr(self, k)[rows], dtype=np.float64)
                     for k in _POSE_KEYS)

    def subsample(self, count: int) -> np.ndarray:
        """Indices of ``count`` rows spread evenly over the set (every pair, every tilt)."""
        count = min(count, len(self))
        return np.unique(np.linspace(0, len(self) - 1, count).round().astype(np.int64))

    def pair_args(self, i: int) -> tuple[np.ndarray, ...]:
        """The six 1-D arguments of pair i (the way a simulator calls for one pair)."""
        return tuple(np.array(getattr(self, k)[i], dtype=np.float64) for k in _POSE_KEYS)


def scene_poses(scene, n: int, seed: int) -> PoseSet:
    """``n`` first-contact poses over every pair of ``scene`` (see the module docstring)."""
    from impactnet.models.geometry.poses import first_contact_poses

    sizes = scene.pair_sizes()
    m = len(sizes)
    per_pair = -(-n // m)
    rng = np.random.default_rng(seed)
    columns, pair = _interleaved([first_contact_poses(per_pair, size_a, size_b, rng,
                                                      depth_fraction=scene.depth_fraction)
                                  for size_a, size_b in sizes], n)
    return PoseSet("scene", **columns, pair=pair,
                   pair_names=tuple((p.a, p.b) for p in scene.pairs),
                   description=f"first contacts of the {m} pairs of scene '{scene.name}', "
                               f"uniform relative orientation, depth "
                               f"{scene.depth_fraction[0]:g}-{scene.depth_fraction[1]:g} of "
                               "the shortest edge")


def _interleaved(groups: list[dict], n: int) -> tuple[dict, np.ndarray]:
    """The pose columns of ``groups`` (dicts of equally long arrays) interleaved row by row,
    the first ``n`` rows, so that any prefix covers every group evenly; and each row's group."""
    m, per_group = len(groups), len(groups[0]["size_a"])
    order = np.arange(per_group * m).reshape(m, per_group).T.reshape(-1)[:n]
    columns = {k: np.concatenate([g[k] for g in groups])[order] for k in _POSE_KEYS}
    return columns, np.repeat(np.arange(m), per_group)[order]


def stacking_set(n: int, seed: int) -> PoseSet:
    """``n`` stacking poses of :mod:`impactnet.training.bench.contact_sets` (B resting on A's
    top face: every family of ``STACKING_FAMILIES`` at every tilt of ``STACKING_TILTS``,
    interleaved); ``pair`` indexes the family (``pair_names``: its name twice), ``tilt``
    holds each row's tilt."""
    from impactnet.training.bench.contact_sets import (
        STACKING_FAMILIES,
        STACKING_TILTS,
        stacking_poses,
    )

    rng = np.random.default_rng(seed)
    per_group = -(-n // (len(STACKING_FAMILIES) * len(STACKING_TILTS)))
    groups = [(k, stacking_poses(per_group, size_a, size_b, tilt, rng))
              for tilt in STACKING_TILTS
              for k, (size_a, size_b) in enumerate(STACKING_FAMILIES.values())]
    columns, group = _interleaved([poses for _, poses in groups], n)
    family = np.array([k for k, _ in groups])[group]
    tilt = np.array([poses["tilt"][0] for _, poses in groups])[group]
    return PoseSet("stacking", **columns, pair=family,
                   pair_names=tuple((name, name) for name in STACKING_FAMILIES), tilt=tilt,
                   description=f"stacking ({', '.join(STACKING_FAMILIES)}): B resting on A's "
                               f"top face, tilts 0 and 1e-12 to 1e-2 rad, offsets up to "
                               "a quarter of A's length and width, pushed 0.1-20 mm")


def figure2_tilts(count: int) -> np.ndarray:
    """``count`` tilts, log-spaced from 10 degrees down to 1e-6 rad."""
    return np.geomspace(FIGURE2_TILT_MAX_RAD, FIGURE2_TILT_MIN_RAD, count)


def figure2_poses(scene, tilts: int, per_tilt: int, seed: int) -> PoseSet:
    """The Figure 2 set: ``per_tilt`` random placements at each of ``tilts`` tilts."""
    names = [b.name for b in scene.bodies] if scene is not None else []
    edge = float(scene.size("cube")[0]) if "cube" in names else FIGURE2_EDGE_M
    pair_index = next((k for k, p in enumerate(scene.pairs) if (p.a, p.b) == ("cube", "cube")),
                      -1) if scene is not None else -1
    rng = np.random.default_rng(seed)
    tilt = np.repeat(figure2_tilts(tilts), per_tilt)
    n = len(tilt)
    yaw = rng.uniform(-np.pi, np.pi, n)
    diagonal = np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0)  # B's bottom-face diagonal axis
    rotation = (Rotation.from_euler("z", yaw[:, None])
                * Rotation.from_rotvec(tilt[:, None] * diagonal))
    corners = 0.5 * edge * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1)
                                     for z in (-1, 1)], dtype=np.float64)
    world = np.einsum("nij,kj->nki", rotation.as_matrix(), corners)  # (n, 8, 3) about B's centre
    lowest = world[np.arange(n), np.argmin(world[:, :, 2], axis=1)]
    target = np.column_stack([rng.uniform(-0.25, 0.25, (n, 2)) * edge,
                              np.full(n, 0.5 * edge - FIGURE2_DEPTH_FRACTION * edge)])
    q = rotation.as_quat(scalar_first=True)
    q = np.where(q[:, :1] < 0.0, -q, q)
    cube = np.full((n, 3), edge)
    return PoseSet("figure2", size_a=cube, position_a=np.zeros((n, 3)),
                   quaternion_a=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), size_b=cube.copy(),
                   position_b=target - lowest, quaternion_b=q,
                   pair=np.full(n, pair_index), pair_names=tuple(
                       (p.a, p.b) for p in scene.pairs) if scene is not None else (),
                   tilt=tilt,
                   description=f"the paper's Figure 2: cubes of edge {edge:g} m, a vertex of B "
                               f"{FIGURE2_DEPTH_FRACTION * edge * 100:g} cm into A's top face, "
                               f"B's face tilted {tilts} ways from 10 deg down to "
                               f"{FIGURE2_TILT_MIN_RAD:g} rad, {per_tilt} placements each")
