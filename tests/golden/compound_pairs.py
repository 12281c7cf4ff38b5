"""Margins of the compound oracle's part pairs (not a test module).

For N poses of two compound bodies: the *near* part pairs (bounds within
:data:`NEAR_SLACK_REL` of touching; any other pair is clearly apart), and for each the margins
of the part solver's decisions in the columns of :data:`tests.golden.rule.BOX_MARGINS`: box
pairs through :mod:`tests.golden.box_margins` (the oracle answers them with the box solver),
pairs with a convex part through :mod:`tests.golden.convex_decide` and
:mod:`tests.golden.convex_faces` (the convex solver's rule). Also the decisions redone here
(colliding, the reference feature and the contact type), for the recorder's model check.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart, bounds
from impactnet.models.geometry.rotations import quaternion_to_matrix
from tests.golden import rule
from tests.golden.box_axes import local_pairs, overlaps
from tests.golden.box_margins import box_margins
from tests.golden.convex_decide import EDGE, FACE_A, convex_decide
from tests.golden.convex_faces import convex_face_margins

#: Part pairs whose bounds overlap within this fraction of the pair's scale (sum of the bounds'
#: largest half-extents) are examined; far above DECISION_TOL_REL, so that no borderline pair
#: is missed, and small enough to keep the examined pairs few.
NEAR_SLACK_REL = 1e-6
#: Type codes of a face contact by incident rank, reference face on A / on B.
REF_A_CODES = (0, ct.FACE_VERTEX, ct.FACE_EDGE, ct.FACE_FACE)
REF_B_CODES = (0, ct.VERTEX_FACE, ct.EDGE_FACE, ct.FACE_FACE)


@dataclass
class PairMargins:
    """Margins of k near part pairs (pose-major) of N poses."""

    pose: np.ndarray  # (k,) int
    part_a: np.ndarray  # (k,) int
    part_b: np.ndarray  # (k,) int
    margins: np.ndarray  # (k, len(BOX_MARGINS)), lengths x the pair's solver scale
    reach: np.ndarray  # (k,)
    scale: np.ndarray  # (k,) the part solver's pair scale (metres)
    tied: np.ndarray  # (k,) box pairs: axis bitmask; convex pairs: 0 (no axis ids)
    tie_width: np.ndarray  # (k,) x scale
    causes: np.ndarray  # (k,) int
    colliding: np.ndarray  # (k,) bool, redone here
    features: np.ndarray  # (k, 2) the redone reference feature(s), -2 where not predicted
    type_code: np.ndarray  # (k,) the redone type, -1 where not predicted


def placed_bounds(parts, position, rot):
    """World centres (n, P, 3) and full sizes (P, 3) of the parts' bounds."""
    lo = np.array([bounds(p)[0] for p in parts])
    hi = np.array([bounds(p)[1] for p in parts])
    centre = position[:, None, :] + np.einsum("nij,pj->npi", rot, 0.5 * (lo + hi))
    return centre, hi - lo


def near_pairs(parts_a, parts_b, poses):
    """(pose, part_a, part_b) of the part pairs whose bounds are within NEAR_SLACK_REL of
    touching, pose-major; ``poses`` = (position_a, q_a, rot_a, position_b, q_b, rot_b)."""
    pos_a, q_a, rot_a, pos_b, q_b, rot_b = poses
    centre_a, size_a = placed_bounds(parts_a, pos_a, rot_a)
    centre_b, size_b = placed_bounds(parts_b, pos_b, rot_b)
    radius_a = 0.5 * np.linalg.norm(size_a, axis=1)
    radius_b = 0.5 * np.linalg.norm(size_b, axis=1)
    gap = np.linalg.norm(centre_a[:, :, None] - centre_b[:, None], axis=3)
    pose, i, j = np.nonzero(gap <= (radius_a[:, None] + radius_b[None]) * (1 + NEAR_SLACK_REL))
    pose_rows = local_pairs(size_a[i], centre_a[pose, i], q_a[pose], size_b[j],
                            centre_b[pose, j], q_b[pose])
    over = overlaps(pose_rows)[0]
    over = np.where(np.isinf(over), 0.0, over)
    keep = over.min(axis=1) >= -NEAR_SLACK_REL * pose_rows.scale
    return pose[keep], i[keep], j[keep]


def _box_rows(parts_a, parts_b, poses, pose, i, j, out):
    """Fill ``out`` (dict of (k, ...) arrays) for the box-box rows ``at``."""
    pos_a, q_a, rot_a, pos_b, q_b, rot_b = poses
    at = np.flatnonzero([isinstance(parts_a[a], BoxPart) and isinstance(parts_b[b], BoxPart)
                         for a, b in zip(i, j)])
    if not at.size:
        return at
    size_a = np.array([parts_a[a].size for a in i[at]], float)
    size_b = np.array([parts_b[b].size for b in j[at]], float)
    centre_a = pos_a[pose[at]] + np.einsum("kij,kj->ki", rot_a[pose[at]],
                                           np.array([parts_a[a].centre for a in i[at]], float))
    centre_b = pos_b[pose[at]] + np.einsum("kij,kj->ki", rot_b[pose[at]],
                                           np.array([parts_b[b].centre for b in j[at]], float))
    found = box_margins(size_a, centre_a, q_a[pose[at]], size_b, centre_b, q_b[pose[at]])
    for name in ("margins", "reach", "scale", "tied", "tie_width", "causes", "colliding"):
        out[name][at] = getattr(found, name)
    out["type_code"][at] = found.type_code
    return at


def _convex_group(hull_a, hull_b, t, rot):
    """Margins (m, K) (lengths in metres), reach, scale, width, colliding, features (m, 2)
    and type codes of m poses of one pair of hulls with a convex part."""
    found = convex_decide(hull_a, hull_b, t, rot)
    m = len(t)
    columns = {name: np.full(m, np.inf) for name in rule.MARGIN_NAMES}
    for name in ("contact", "tie", "band"):
        columns[name] = found.margins[name]
    features, codes = np.full((m, 2), -2), np.where(found.colliding, -1, ct.NONE)
    tol = rule.DECISION_TOL_REL * found.margins["reach"] * found.scale
    for kind, ref, inc in ((FACE_A, hull_a, hull_b), (FACE_A + 1, hull_b, hull_a)):
        rows = np.flatnonzero(found.colliding & (found.kind == kind))
        if not rows.size:
            continue
        if kind == FACE_A:
            rot_inc, x_inc = rot[rows], t[rows, None] + np.einsum("mij,vj->mvi", rot[rows],
                                                                  hull_b.vertices)
            planes = [(r @ hull_b.face_normals.T).T for r in rot_inc]
            planes = [(nb, hull_b.face_offsets + nb @ tt) for nb, tt in zip(planes, t[rows])]
        else:
            rot_inc = rot[rows].transpose(0, 2, 1)
            x_inc = np.einsum("mji,mvj->mvi", rot[rows], hull_a.vertices[None] - t[rows, None])
            planes = [((r @ hull_a.face_normals.T).T, hull_a.face_offsets
                       - (r @ hull_a.face_normals.T).T @ (r @ tt)) for r, tt in zip(rot_inc,
                                                                                  t[rows])]
        faces = convex_face_margins(ref, found.face[rows], inc, x_inc, rot_inc, planes,
                                    found.sat_depth[rows], found.scale[rows], tol[rows])
        for name in ("feature_unit", "feature_depth", "clip", "region", "empty"):
            columns[name][rows] = faces[name]
        features[rows, kind] = found.face[rows]
        codes[rows] = np.array(REF_A_CODES if kind == FACE_A else REF_B_CODES)[faces["rank"]]
    edge = found.colliding & (found.kind == EDGE)
    features[edge] = found.edges[edge] + np.array([hull_a.n_faces, hull_b.n_faces])
    codes[edge] = ct.EDGE_EDGE
    return columns, found, features, codes


def pair_margins(parts_a, parts_b, poses) -> PairMargins:
    """:class:`PairMargins` of the near part pairs of N poses (see :func:`near_pairs`)."""
    pose, i, j = near_pairs(parts_a, parts_b, poses)
    k = len(pose)
    out = {"margins": np.full((k, len(rule.MARGIN_NAMES)), np.inf), "reach": np.ones(k),
           "scale": np.ones(k), "tied": np.zeros(k, np.int64), "tie_width": np.zeros(k),
           "causes": np.zeros(k, np.int64), "colliding": np.zeros(k, bool),
           "features": np.full((k, 2), -2), "type_code": np.full(k, -1)}
    boxes = _box_rows(parts_a, parts_b, poses, pose, i, j, out)
    pos_a, _, rot_a, pos_b, _, rot_b = poses
    rest = np.setdiff1d(np.arange(k), boxes)
    for a, b in sorted(set(zip(i[rest].tolist(), j[rest].tolist()))):
        rows = rest[(i[rest] == a) & (j[rest] == b)]
        ra_t = rot_a[pose[rows]].transpose(0, 2, 1)
        t = np.einsum("kij,kj->ki", ra_t, pos_b[pose[rows]] - pos_a[pose[rows]])
        columns, found, features, codes = _convex_group(hull_of(parts_a[a]), hull_of(parts_b[b]),
                                                        t, ra_t @ rot_b[pose[rows]])
        kinds = {name: kind for name, kind, _ in rule.BOX_MARGINS}
        table = np.stack([columns[n] / (found.scale if kinds[n] == "length" else 1.0)
                          for n in rule.MARGIN_NAMES], axis=1)
        reach = found.margins["reach"]
        out["margins"][rows], out["reach"][rows], out["scale"][rows] = table, reach, found.scale
        out["tie_width"][rows] = found.tie_width / found.scale
        out["causes"][rows] = rule.causes_of(table, reach)
        out["colliding"][rows], out["features"][rows] = found.colliding, features
        out["type_code"][rows] = codes
    return PairMargins(pose, i, j, **out)


def body_poses(position_a, quaternion_a, position_b, quaternion_b):
    """(position_a, q_a, rot_a, position_b, q_b, rot_b) of N poses, quaternions normalised."""
    q_a = quaternion_a / np.linalg.norm(quaternion_a, axis=1, keepdims=True)
    q_b = quaternion_b / np.linalg.norm(quaternion_b, axis=1, keepdims=True)
    return (position_a, q_a, quaternion_to_matrix(q_a), position_b, q_b,
            quaternion_to_matrix(q_b))
