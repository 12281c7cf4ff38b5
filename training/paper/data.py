"""The paper's data sets: the cube pair at first contact, labelled with the paper's four angles.

Protocol (the paper's section IV, as impactnet reads it; docs/design.md, "References"):

1. Two cubes of edge 2 m. B's orientation relative to A: Euler angles roll, pitch, yaw each uniform
   in [-pi/2, pi/2], ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (:mod:`impactnet.models.geometry.rotations`
   "zyx"); a random approach direction; B moved to first touch along it and pushed in by a small
   depth (:func:`impactnet.models.geometry.poses.first_contact_poses`, ``orientation="paper"``).
2. Everything is expressed with A at the origin and identity orientation; the exact solver
   (:func:`impactnet.models.box.exact.box_box`) labels each pair.
3. Inputs (6): B's centre in A's frame (x, y, z, metres), then B's Euler angles relative to A (roll,
   pitch, yaw, radians). Targets (4): :func:`impactnet.models.geometry.spherical.paper_angles`.

"With discontinuities": every contact of that stream. "Without discontinuities": one region,
:data:`CANONICAL_REGION` = (face-vertex, A's face +x, B's vertex (-,-,-)): B's corner on A's +x
face. Inside it the point is the centre of pressure of the small footprint around B's corner (within
the depth of the corner) and the normal is A's +x normal, both smooth in the pose. The 8 sign flips
``S = diag(s)``, applied to both boxes (``t -> S t``, ``R -> S R S``), leave the whole sampling
distribution unchanged (they map (roll, pitch, yaw) to (s1 s2 roll, s0 s2 pitch, s0 s1 yaw), a
uniform draw on the symmetric box to itself, and a uniform direction to a uniform direction); they
map the 8 mirror images of the region (A's face +-x, B's vertex with the opposite x sign) onto it.
So the data are drawn by rejection from the stream, each mirror-image row folded onto the canonical
region by its flip and re-labelled by the exact solver; the result is distributed as the stream
conditioned on the region, at 8x the yield. Rows whose fresh label is not the region (ties on a
region boundary) are dropped and counted.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.exact import box_box
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.poses import first_contact_poses
from impactnet.models.geometry.rotations import (
    euler_to_matrix,
    matrix_to_euler,
    matrix_to_quaternion,
    quaternion_to_matrix,
)
from impactnet.models.geometry.spherical import paper_angles

INPUT_NAMES = ("x", "y", "z", "roll", "pitch", "yaw")
OUTPUT_NAMES = ("point azimuth", "point elevation", "force azimuth", "force elevation")
#: Output columns that are azimuths (wrapped before errors are measured).
AZIMUTH_COLUMNS = (0, 2)
#: (contact type code, feature of A, feature of B) of the "without discontinuities" problem.
CANONICAL_REGION = (ct.FACE_VERTEX, int(bf.face_id(0, False)), int(bf.vertex_id(1, 1, 1)))


@dataclass
class PaperDataConfig:
    edge: float = 2.0  # cube edge in metres (the paper: "two boxes of edge 2")
    depth_fraction: tuple[float, float] = (0.0, 0.01)  # push depth range, fraction of the edge
    chunk: int = 200_000  # poses drawn per batch of the stream (bounds memory, not results)


@dataclass
class PaperSet:
    """N labelled pairs in A's frame (A at the origin, identity orientation)."""

    inputs: np.ndarray  # (n, 6) B's centre (m) and Euler angles (rad), see INPUT_NAMES
    targets: np.ndarray  # (n, 4) the paper's angles (rad), see OUTPUT_NAMES
    point: np.ndarray  # (n, 3) exact impact point in A's frame (m)
    normal: np.ndarray  # (n, 3) exact unit normal in A's frame, from A towards B
    depth: np.ndarray  # (n,) penetration depth (m)
    contact_type_code: np.ndarray  # (n,) int8, index into impactnet.models.contacts.CONTACT_TYPES
    feature_a: np.ndarray  # (n,) int8 feature id of A (impactnet.models.geometry.box_features)
    feature_b: np.ndarray  # (n,) int8 feature id of B

    def __len__(self) -> int:
        return len(self.inputs)

    def take(self, index) -> PaperSet:
        return PaperSet(**{k: v[index] for k, v in vars(self).items()})

    @staticmethod
    def concat(parts) -> PaperSet:
        return PaperSet(**{k: np.concatenate([getattr(p, k) for p in parts])
                           for k in vars(parts[0])})


def label(translation, euler, config: PaperDataConfig) -> PaperSet:
    """Exact labels of B at ``translation`` (n, 3) with Euler angles ``euler`` (n, 3), A fixed."""
    n = len(translation)
    cube = np.full((n, 3), config.edge)
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    quaternion_b = matrix_to_quaternion(euler_to_matrix(euler))
    c = box_box(cube, np.zeros((n, 3)), identity, cube, translation, quaternion_b)
    if not c.colliding.all():
        raise RuntimeError(f"{int((~c.colliding).sum())} pairs of the paper's stream separated")
    return PaperSet(
        inputs=np.column_stack([translation, euler]),
        targets=paper_angles(c.point, c.normal, np.zeros(3), np.eye(3)),
        point=c.point, normal=c.normal, depth=c.depth,
        contact_type_code=c.contact_type_code, feature_a=c.feature_a, feature_b=c.feature_b)


def stream(n, rng, config: PaperDataConfig) -> PaperSet:
    """n labelled pairs of the paper's protocol (every contact: "with discontinuities")."""
    cube = (config.edge,) * 3
    poses = first_contact_poses(n, cube, cube, rng, depth_fraction=config.depth_fraction,
                                orientation="paper")
    rot_a = quaternion_to_matrix(poses["quaternion_a"])
    rot_ab = np.swapaxes(rot_a, 1, 2) @ quaternion_to_matrix(poses["quaternion_b"])
    translation = np.einsum("nji,nj->ni", rot_a, poses["position_b"] - poses["position_a"])
    # Unique for |pitch| < pi/2, so these are the sampler's own draws (to round-off).
    return label(translation, matrix_to_euler(rot_ab), config)


def mirror_flips(data: PaperSet) -> tuple[np.ndarray, np.ndarray]:
    """Rows in the 8 mirror images of CANONICAL_REGION and the flips ``s`` (k, 3) that fold them.

    Returns ``(rows, s)``: ``diag(s)`` maps A's face of the row to +x and B's vertex to (-,-,-).
    """
    code, face, vertex = CANONICAL_REGION
    vertex_sign = bf.FEATURE_SIGNS[vertex]
    fa, fb = data.feature_a.astype(np.int64), data.feature_b.astype(np.int64)
    face_sign = bf.FEATURE_SIGNS[np.clip(fa, 0, None)] @ bf.FEATURE_SIGNS[face]  # +-1 or 0
    rows = np.flatnonzero((data.contact_type_code == code) & (fa >= 0) & (fa < bf.EDGE_BASE)
                          & (face_sign != 0) & (fb >= bf.VERTEX_BASE))
    signs_b = bf.FEATURE_SIGNS[fb[rows]]
    s = signs_b * vertex_sign  # flips B's vertex onto the canonical one, per axis
    keep = s[:, 0] == face_sign[rows]  # the same flip must take A's face onto +x
    return rows[keep], s[keep].astype(np.float64)


def fold(data: PaperSet, rows, s, config: PaperDataConfig) -> PaperSet:
    """The poses of ``rows`` mirrored by ``diag(s)`` (both boxes) and labelled afresh."""
    x = data.inputs[rows]
    euler_sign = np.column_stack([s[:, 1] * s[:, 2], s[:, 0] * s[:, 2], s[:, 0] * s[:, 1]])
    return label(s * x[:, :3], euler_sign * x[:, 3:], config)


def in_region(data: PaperSet, region=CANONICAL_REGION) -> np.ndarray:
    """Boolean mask of the rows whose label is exactly ``region`` (type code, feature A, B)."""
    code, fa, fb = region
    return (data.contact_type_code == code) & (data.feature_a == fa) & (data.feature_b == fb)


@dataclass
class RegionStats:
    """How the "without discontinuities" set was drawn (for the report)."""

    drawn: int  # pairs drawn from the paper's stream
    canonical: int  # of which already in CANONICAL_REGION
    mirrored: int  # of which in one of its 8 mirror images (canonical ones included)
    dropped: int  # folded rows whose fresh label left the region (boundary ties)


def region_set(n, rng, config: PaperDataConfig) -> tuple[PaperSet, RegionStats]:
    """n pairs of the paper's stream restricted to CANONICAL_REGION ("without discontinuities")."""
    parts, have, stats = [], 0, RegionStats(0, 0, 0, 0)
    while have < n:
        batch = stream(config.chunk, rng, config)
        rows, s = mirror_flips(batch)
        folded = fold(batch, rows, s, config)
        ok = in_region(folded)
        stats.drawn += len(batch)
        stats.canonical += int(in_region(batch).sum())
        stats.mirrored += len(rows)
        stats.dropped += int((~ok).sum())
        parts.append(folded.take(np.flatnonzero(ok)))
        have += int(ok.sum())
    return PaperSet.concat(parts).take(np.arange(n)), stats


def split(data: PaperSet, sizes) -> dict[str, PaperSet]:
    """Consecutive training / validation / test sets of the given sizes (the rows are iid)."""
    train, val, test = sizes
    if len(data) < train + val + test:
        raise ValueError(f"{len(data)} rows cannot fill sets of {sizes}")
    edges = np.cumsum([0, train, val, test])
    names = ("training", "cross_validation", "external_validation")
    return {name: data.take(np.arange(edges[i], edges[i + 1])) for i, name in enumerate(names)}
