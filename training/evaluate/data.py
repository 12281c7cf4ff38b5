"""The held-out test set of `impactnet evaluate` and each row's distance to a region boundary.

Test rows (:func:`test_rows`): :func:`impactnet.training.data.datagen.generate_pairs` with the
pair's sizes, the scene's depth range and the orientation families the bundle was trained with (its
manifest's ``datagen`` config; the defaults where the manifest does not say), drawn from the stream
:data:`EVAL_STREAM` of the pair's seed. Training draws chunk ``k`` of a pair from spawn key
``pair + (k,)`` and its torch generators from ``pair + (2_000_00x,)``; the test set draws from
``pair + (EVAL_STREAM, k)``, so it shares no random numbers with any training run, even at the same
``--seed``. Labels come from the exact solver, as in training.

Boundary distance (:func:`boundary_distance`), on rows the exact solver calls colliding, as a
fraction of the pair's shortest edge ``e`` (the smaller body's shortest edge):

* ``sat_margin``: the gap between the smallest of the 15 separating-axis overlaps
  (:func:`impactnet.models.geometry.approach.axis_overlaps`, metres) and the smallest on an axis of
  another direction (aligned boxes share face axes: no boundary between those). Where it is 0 the
  axis of least penetration, and with it the normal and the reference feature, is about to switch.
* ``vertex_gap`` (face axes only; +inf for edge-edge): the incident box's 8 vertices, signed
  penetration beyond the reference face's plane along the normal, sorted deepest first; the
  contact type counts the penetrating vertices (1: vertex, 2: edge, 3-4: face), so it changes
  when the second or third deepest crosses the plane. ``vertex_gap`` = min(|d2|, |d3|).
* ``distance`` = min of the two: how far (in e) the pose is from the nearest region boundary.
  It is a lower bound: an axis switch can keep the region (near-parallel faces in face-face
  contact: A's face or B's as reference, the same features), and other boundaries (the
  incident face changing) are not measured.

The deepest vertex crossing the plane (contact vs none) is not counted: at the scene's depths
(0-1 % of e) every contact is that close to it by construction.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.approach import axis_overlaps, axis_terms
from impactnet.models.geometry.rotations import quaternion_to_matrix
from impactnet.models.scenes import Scene
from impactnet.training.data.datagen import DatagenConfig, generate_pairs, pair_seed
from impactnet.training.data.pair_data import stream

#: Spawn-key suffix (under the pair's seed) of the test rows; training uses chunk indices
#: 0, 1, ..., the split stream 1_000_001 and torch streams 2_000_00x.
EVAL_STREAM = 3_000_001
#: The six pose inputs, in ``box_box`` order.
INPUTS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
#: Two separating axes whose directions differ by a sine below this (dimensionless) are one
#: axis (e.g. A's and B's face normals of aligned boxes): a switch between them is no boundary.
SAME_AXIS_SINE = 1e-9
#: Axis ids below this are face axes (0-2 A's, 3-5 B's); the rest are edge-edge cross axes.
FACE_AXES = 6
#: Sign patterns of a box's 8 vertices (8, 3).
VERTEX_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                        dtype=np.float64)


def datagen_config(manifest: dict) -> DatagenConfig:
    """The orientation families a bundle was trained with (defaults where not recorded).

    Parameters
    ----------
    manifest : dict
        The bundle's ``manifest.json``; ``training.config.pair.datagen`` is read if present.
    """
    try:
        recorded = dict(manifest["training"]["config"]["pair"]["datagen"])
    except (KeyError, TypeError):
        return DatagenConfig()
    known = set(DatagenConfig.__dataclass_fields__)
    recorded = {k: tuple(v) if isinstance(v, list) else v for k, v in recorded.items()
                if k in known}
    return DatagenConfig(**recorded)


def held_out_rows(scene: Scene, index: int, rows: int, seed: int,
                  datagen: DatagenConfig, suffix: int = EVAL_STREAM) -> dict[str, np.ndarray]:
    """Held-out labelled rows of ``scene.pairs[index]`` (module docstring), from the stream
    ``suffix`` under the pair's seed (:data:`EVAL_STREAM`; the validation gate uses its own).

    Returns
    -------
    dict of ndarray
        The columns of :func:`impactnet.training.data.datagen.generate_pairs` (``rows`` each), plus
        ``edge`` (float, metres): the smaller body's shortest edge of the pair.
    """
    pair = scene.pairs[index]
    size_a, size_b = scene.pair_sizes()[index]
    data = generate_pairs(size_a, size_b, rows, stream(pair_seed(seed, pair), suffix),
                          datagen, depth_fraction=scene.depth_fraction, progress=False)
    data["edge"] = float(scene.smaller_shortest_edge(pair))
    return data


def relative_pose(data: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A's rotation (n, 3, 3), B's axes in A's frame ``R_A^T R_B`` (n, 3, 3) and B's centre in
    A's frame ``R_A^T (p_B - p_A)`` (n, 3, metres) of test rows."""
    rot_a = quaternion_to_matrix(data["quaternion_a"])
    rot_b = quaternion_to_matrix(data["quaternion_b"])
    rotation = np.einsum("nji,njk->nik", rot_a, rot_b)
    offset = np.einsum("nji,nj->ni", rot_a, data["position_b"] - data["position_a"])
    return rot_a, rotation, offset


def sat_margin(size_a, size_b, rotation: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Gap (n,) in metres between the least overlap of the 15 separating axes and the least
    overlap of the axes that are not parallel to its axis (within :data:`SAME_AXIS_SINE`).

    Parameters
    ----------
    size_a, size_b : ndarray, shape (n, 3)
        Full edge lengths, metres.
    rotation, offset : ndarray, shape (n, 3, 3) and (n, 3)
        B's axes and centre in A's frame (:func:`relative_pose`).
    """
    axes, _, length, valid = axis_terms(size_a, size_b, rotation)
    overlaps = axis_overlaps(size_a, size_b, rotation, offset)
    best = np.argmin(overlaps, axis=1)
    unit = axes / np.where(valid, length, 1.0)[..., None]
    winner = np.take_along_axis(unit, best[:, None, None], axis=1)
    sine = np.linalg.norm(np.cross(unit, winner), axis=2)
    others = np.where(valid & (sine > SAME_AXIS_SINE), overlaps, np.inf).min(axis=1)
    return others - np.take_along_axis(overlaps, best[:, None], axis=1)[:, 0]


def vertex_penetrations(data: dict, rot_a: np.ndarray, rotation: np.ndarray,
                        offset: np.ndarray) -> np.ndarray:
    """Signed penetrations (n, 8), metres, of the incident box's vertices beyond the reference
    face's plane along the exact normal, deepest first (positive: beyond the plane).

    Reference face on A (axis 0-2): B's vertices ``v``, ``d = r_A - n.v`` with ``r_A`` A's
    support along n. Reference face on B (axis 3-5): A's vertices ``w``,
    ``d = n.w - (n.t - r_B)``. Everything in A's frame; edge-edge rows are meaningless here.
    """
    half_a, half_b = 0.5 * data["size_a"], 0.5 * data["size_b"]
    normal = np.einsum("nji,nj->ni", rot_a, data["normal"])  # A's frame
    normal_b = np.einsum("nji,nj->ni", rotation, normal)  # B's frame
    r_a = (half_a * np.abs(normal)).sum(axis=1)
    r_b = (half_b * np.abs(normal_b)).sum(axis=1)
    # n.v for B's vertices v = t + R (s * h_B): n.t + (R^T n) . (s * h_B)
    along_b = (normal * offset).sum(axis=1)[:, None] + (normal_b * half_b) @ VERTEX_SIGNS.T
    along_a = (normal * half_a) @ VERTEX_SIGNS.T  # n.w for A's vertices w = s * h_A
    on_a = (data["axis"] < 3)[:, None]
    depth = np.where(on_a, r_a[:, None] - along_b,
                     along_a - ((normal * offset).sum(axis=1) - r_b)[:, None])
    return -np.sort(-depth, axis=1)


def boundary_distance(data: dict) -> dict[str, np.ndarray]:
    """``sat_margin``, ``vertex_gap`` and ``distance`` (n,) as fractions of the pair's edge e
    (module docstring); NaN on rows the exact solver calls separated."""
    rot_a, rotation, offset = relative_pose(data)
    margin = sat_margin(data["size_a"], data["size_b"], rotation, offset) / data["edge"]
    depth = vertex_penetrations(data, rot_a, rotation, offset)
    gap = np.minimum(np.abs(depth[:, 1]), np.abs(depth[:, 2])) / data["edge"]
    gap = np.where(data["axis"] < FACE_AXES, gap, np.inf)
    separated = ~data["colliding"]
    out = {"sat_margin": margin, "vertex_gap": gap, "distance": np.minimum(margin, gap)}
    for values in out.values():
        values[separated] = np.nan
    return out
