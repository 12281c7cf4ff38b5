"""Margins of the compound oracle's covered-surface filter and of its summary (not a test
module).

* Filter (:mod:`impactnet.models.compound.oracle`, stage 4): a part contact is dropped when all
  of its manifold points, moved from the mid-surface back onto one body's part, lie inside
  other parts of that body by more than ``INSIDE_MARGIN_REL`` of their smallest edge. A point's
  insideness in a part is ``max`` of its per-plane excesses (inside iff < 0), its insideness in
  the body the ``min`` over the other parts; the contact is covered iff the ``max`` over its
  points is < 0, and hidden iff A's or B's side is covered. The margin is the |value| that
  decides (metres).
* Summary (:mod:`impactnet.models.compound.summary`): the deepest contact's normal sets the
  cluster (normals within 10 deg). Any contact within the borderline length of the deepest
  could be the reference: the margin is 0 where those candidates give different clusters,
  else the smallest |angle - 10 deg| (radians) over the candidates and contacts.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.oracle import INSIDE_MARGIN_REL
from impactnet.models.compound.parts import BoxPart, bounds
from impactnet.models.compound.summary import CLUSTER_ANGLE_DEG
from impactnet.models.metrics import angle_deg
from tests.golden import rule


class Body:
    """A body's parts as the filter sees them: bounds, box flags, inside planes, partners."""

    def __init__(self, parts):
        lo = np.array([bounds(p)[0] for p in parts])
        hi = np.array([bounds(p)[1] for p in parts])
        self.centre, self.half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        self.is_box = np.array([isinstance(p, BoxPart) for p in parts])
        self.margin = INSIDE_MARGIN_REL * (hi - lo).min(axis=1)
        self.planes = [hull_of(p).inside_planes() for p in parts]
        overlap = ((lo[:, None] < hi[None]) & (lo[None] < hi[:, None])).all(axis=2)
        np.fill_diagonal(overlap, False)
        self.partners = [np.flatnonzero(row) for row in overlap]

    def outside(self, local: np.ndarray, own: int) -> np.ndarray:
        """(k,) the insideness value of points ``local`` (k, 3, body frame) in the body's
        parts other than ``own`` (inside some part iff < 0; +inf with no partner)."""
        best = np.full(len(local), np.inf)
        for part in self.partners[own]:
            gap = np.abs(local - self.centre[part])
            if self.is_box[part]:
                value = (gap - (self.half[part] - self.margin[part])).max(axis=1)
            else:
                normals, offsets = self.planes[part]
                depth = (local @ normals.T - offsets).max(axis=1)
                value = np.maximum((gap - self.half[part]).max(axis=1), depth + self.margin[part])
            best = np.minimum(best, value)
        return best


def filter_value(contact: dict, body_a: Body, body_b: Body, poses, pose, i, j) -> float:
    """The filter's deciding value (metres) of one colliding part pair, from its raw contact
    (``normal`` (3,), ``manifold_points`` (c, 3), ``manifold_depths`` (c,)): hidden iff < 0,
    the margin is its size; +inf where it has no manifold point."""
    pos_a, _, rot_a, pos_b, _, rot_b = poses
    points, depths = contact["manifold_points"], contact["manifold_depths"]
    if len(points) == 0:
        return np.inf
    half = 0.5 * depths[:, None] * contact["normal"][None]
    side_a = body_a.outside((points + half - pos_a[pose]) @ rot_a[pose], i).max()
    side_b = body_b.outside((points - half - pos_b[pose]) @ rot_b[pose], j).max()
    return float(min(side_a, side_b))


def summary_margin(depth: np.ndarray, normal: np.ndarray, tol: float) -> float:
    """The summary's margin (radians) of one pose from its part contacts' depths (c,) and
    normals (c, 3) (module docstring); +inf without contacts."""
    if len(depth) == 0:
        return np.inf
    candidates = np.flatnonzero(depth >= depth.max() - tol)
    angles = np.stack([angle_deg(normal, np.broadcast_to(normal[c], normal.shape))
                       for c in candidates])
    members = angles <= CLUSTER_ANGLE_DEG
    if (members != members[:1]).any():
        return 0.0
    return float(np.deg2rad(np.abs(angles - CLUSTER_ANGLE_DEG)).min())


def summary_margins(offsets, depth, normal, envelope: float) -> np.ndarray:
    """(n,) :func:`summary_margin` of every pose of a ragged answer."""
    tol = rule.DECISION_TOL_REL * envelope
    return np.array([summary_margin(depth[s:e], normal[s:e], tol)
                     for s, e in zip(offsets[:-1], offsets[1:])])
