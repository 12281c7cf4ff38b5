"""Separating-axis test of two convex polyhedra, vectorised over m rows: poses of one pair of
hulls, or of several pairs at once (each row names its hulls in two
:class:`~impactnet.models.compound.hull_stack.HullStack`; a row's answer does not depend on the
others, nor on the padding).

Frame: A's body frame. Hull A's vertices are as built (:mod:`impactnet.models.compound.hull`);
hull B's are ``y = R v + t`` for each pose. Candidate axes:

* A's face normals: separation ``min_B (n . y) - h`` (B's vertices against A's plane);
* B's face normals, the same the other way round;
* for every edge of A and edge of B whose Gauss-map arcs cross (the pair spans a face of the
  Minkowski difference; Gregorius, "The Separating Axis Test between Convex Polyhedra", GDC
  2013): the cross product of the two edges, oriented away from A, separation
  ``u . (q0 - p0)`` between the two edges' lines. Only those pairs can separate the hulls or
  give the least penetration, so the others are skipped: the cost is ``F_a V_b + F_b V_a``
  for the faces plus ``E_a E_b`` cheap arc tests, and it grows with the parts' detail.

The hulls touch iff no axis separates them by more than :data:`CONTACT_TOL_REL` of the pair's
scale (the sum of both hulls' largest half-extents). The contact axis follows the box solver's
tie rule (:mod:`impactnet.models.box.sat`) with the same constants:

1. the face axis of least overlap, ties within :data:`TIE_TOL_REL` to the lowest index (A's
   faces before B's);
2. an edge axis within :data:`FACE_AXIS_ANGLE_TOL` of that face's normal never wins: it
   competes as that face, with its own overlap where that is smaller (the face's depth stays
   its own);
3. another edge axis wins only if shallower by more than :data:`DEPTH_GAIN_TOL_REL`, and only
   where the closest points of its two edges lie inside both edges
   (:data:`EDGE_INSIDE_TOL_REL`).

Every quantity is an elementwise sum of products (no BLAS reductions), so a pose gives the same
bits alone (N = 1) as in a batch.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.box.tolerances import (
    CONTACT_TOL_REL,
    DEPTH_GAIN_TOL_REL,
    EDGE_INSIDE_TOL_REL,
    EDGE_SKEW_TOL_REL,
    FACE_AXIS_COS_TOL,
    TIE_TOL_REL,
)
from impactnet.models.compound.hull import Hull
from impactnet.models.compound.hull_stack import HullStack, stack_hulls

#: Kinds of contact axis.
FACE_A, FACE_B, EDGE = 0, 1, 2


@dataclass
class AxisChoice:
    """The separating-axis test's answer for m poses (A's body frame)."""

    colliding: np.ndarray  # (m,) bool
    kind: np.ndarray  # (m,) FACE_A, FACE_B or EDGE
    face: np.ndarray  # (m,) the reference face (index into its own hull), -1 for EDGE
    depth: np.ndarray  # (m,) overlap along the axis (m); 0 where separated
    normal: np.ndarray  # (m, 3) unit, from A towards B (separated: the most separating axis)
    edge_a: np.ndarray  # (m,) A's edge of an edge contact, else -1
    edge_b: np.ndarray  # (m,) B's edge of an edge contact, else -1
    edge_point: np.ndarray  # (m, 3) midpoint of the edges' closest points (EDGE rows)
    scale: np.ndarray  # (m,) the pair's scale (m)


def dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Sum over the last axis of 3 of ``x * y`` (broadcast), written out term by term."""
    return x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1] + x[..., 2] * y[..., 2]


def cross(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cross products over the last axis of 3 (broadcast)."""
    return np.stack([x[..., 1] * y[..., 2] - x[..., 2] * y[..., 1],
                     x[..., 2] * y[..., 0] - x[..., 0] * y[..., 2],
                     x[..., 0] * y[..., 1] - x[..., 1] * y[..., 0]], axis=-1)


def rotate(rot: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R v`` for rotations (m, 3, 3) and vectors (K, 3), or each row's own (m, K, 3): shape
    (m, K, 3)."""
    v = v[None] if v.ndim == 2 else v
    return np.stack([dot(rot[:, None, i, :], v) for i in range(3)], axis=-1)


def stacked(hulls: Hull | HullStack, index, m: int) -> tuple[HullStack, np.ndarray]:
    """(stack, row index (m,)) of a hull (every row) or of a stack and its rows' indices."""
    if isinstance(hulls, Hull):
        return stack_hulls((hulls,)), np.zeros(m, np.int64)
    return hulls, np.asarray(index, np.int64)


def face_separations(sa: HullStack, ia, sb: HullStack, ib, y_b: np.ndarray, t: np.ndarray,
                     rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Separations along A's faces (m, F_a) and B's faces (m, F_b), metres."""
    n_a, h_a = sa.face_normals[ia], sa.face_offsets[ia]
    sep_a = dot(y_b[:, :, None, :], n_a[:, None]).min(axis=1) - h_a
    n_b = rotate(rot, sb.face_normals[ib])  # (m, F_b, 3)
    h_b = sb.face_offsets[ib] + dot(n_b, t[:, None, :])
    sep_b = dot(sa.vertices[ia][:, :, None, :], n_b[:, None]).min(axis=1) - h_b
    return sep_a, sep_b


def edge_candidates(sa: HullStack, ia, sb: HullStack, ib, rot: np.ndarray):
    """(row, edge_a, edge_b) of the edge pairs whose Gauss-map arcs cross, row-major."""
    normals_a = sa.edge_normals[ia]  # (m, E_a, 2, 3)
    a, b = normals_a[:, :, 0], normals_a[:, :, 1]
    b_x_a = sa.edge_arcs[ia]
    normals_b = sb.edge_normals[ib]
    c, d = -rotate(rot, normals_b[:, :, 0]), -rotate(rot, normals_b[:, :, 1])  # B's, negated
    d_x_c = rotate(rot, sb.edge_arcs[ib])  # = d x c
    cba = dot(c[:, None], b_x_a[:, :, None])  # (m, E_a, E_b)
    dba = dot(d[:, None], b_x_a[:, :, None])
    adc = dot(a[:, :, None], d_x_c[:, None])
    bdc = dot(b[:, :, None], d_x_c[:, None])
    crossing = ((cba * dba < 0.0) & (adc * bdc < 0.0) & (cba * bdc > 0.0)
                & sa.edge_valid[ia][:, :, None] & sb.edge_valid[ib][:, None, :])
    return np.nonzero(crossing)


def edge_axes(sa: HullStack, ia, sb: HullStack, ib, y_b: np.ndarray, scale: np.ndarray, rows,
              ea, eb):
    """Axes, separations and closest points of the candidate edge pairs (k items).

    Returns
    -------
    axis (k, 3) unit away from A, separation (k,) metres, usable (k,) bool (not parallel),
    inside (k,) bool (closest points inside both edges), midpoint (k, 3).
    """
    hull_a, hull_b = ia[rows], ib[rows]
    ends_a, ends_b = sa.edges[hull_a, ea], sb.edges[hull_b, eb]
    p0 = sa.vertices[hull_a, ends_a[:, 0]]
    p1 = sa.vertices[hull_a, ends_a[:, 1]]
    q0 = y_b[rows, ends_b[:, 0]]
    q1 = y_b[rows, ends_b[:, 1]]
    da, db = p1 - p0, q1 - q0
    axis = cross(da, db)
    length = np.sqrt(dot(axis, axis))
    la, lb = np.sqrt(dot(da, da)), np.sqrt(dot(db, db))
    usable = length > EDGE_SKEW_TOL_REL * scale[rows] * np.minimum(la, lb)
    axis = axis / np.where(usable, length, 1.0)[:, None]
    flip = dot(axis, p0 - sa.centre[hull_a]) < 0.0
    axis = np.where(flip[:, None], -axis, axis)
    separation = dot(axis, q0 - p0)
    s, u = _closest_parameters(p0, da, q0, db)
    slack_a = EDGE_INSIDE_TOL_REL * scale[rows] / np.where(usable, la, 1.0)
    slack_b = EDGE_INSIDE_TOL_REL * scale[rows] / np.where(usable, lb, 1.0)
    inside = ((s >= -slack_a) & (s <= 1 + slack_a) & (u >= -slack_b) & (u <= 1 + slack_b))
    midpoint = 0.5 * ((p0 + s[:, None] * da) + (q0 + u[:, None] * db))
    return axis, separation, usable, inside, midpoint


def _closest_parameters(p0, da, q0, db):
    """Parameters (s, u) of the closest points of the lines p0 + s da and q0 + u db."""
    r = p0 - q0
    aa, bb, ab = dot(da, da), dot(db, db), dot(da, db)
    ar, br = dot(da, r), dot(db, r)
    denominator = aa * bb - ab * ab
    safe = np.where(denominator > 0.0, denominator, 1.0)
    s = np.where(denominator > 0.0, (ab * br - bb * ar) / safe, 0.0)
    u = np.where(denominator > 0.0, (aa * br - ab * ar) / safe, 0.0)
    return s, u


def _first_per_row(rows: np.ndarray, key: np.ndarray, m: int) -> np.ndarray:
    """(m,) the item with the smallest ``key`` of each row (lowest item on ties), -1 if none."""
    best = np.full(m, -1, np.int64)
    if len(rows):
        order = np.lexsort((np.arange(len(rows)), key, rows))
        first = np.ones(len(order), bool)
        first[1:] = rows[order[1:]] != rows[order[:-1]]
        best[rows[order[first]]] = order[first]
    return best


def choose_axis(hull_a: Hull | HullStack, hull_b: Hull | HullStack, t: np.ndarray,
                rot: np.ndarray, index_a=None, index_b=None) -> AxisChoice:
    """The contact axis of m rows (module docstring).

    Parameters
    ----------
    hull_a, hull_b : Hull or HullStack
        The parts, each in its body's frame: one hull for every row, or a stack whose hull of
        row i is ``index_a[i]`` (``index_b[i]``).
    t : ndarray, shape (m, 3)
        B's body origin in A's body frame (metres).
    rot : ndarray, shape (m, 3, 3)
        B's body rotation in A's body frame.
    index_a, index_b : array_like of int, shape (m,), optional
        Each row's hull in a stack.
    """
    m = len(t)
    sa, ia = stacked(hull_a, index_a, m)
    sb, ib = stacked(hull_b, index_b, m)
    scale = sa.half_extent[ia] + sb.half_extent[ib]
    y_b = t[:, None, :] + rotate(rot, sb.vertices[ib])
    sep_a, sep_b = face_separations(sa, ia, sb, ib, y_b, t, rot)
    rows, ea, eb = edge_candidates(sa, ia, sb, ib, rot)
    axis, sep_e, usable, inside, mid = edge_axes(sa, ia, sb, ib, y_b, scale, rows, ea, eb)
    rows, ea, eb, axis, sep_e, inside, mid = (x[usable] for x in
                                               (rows, ea, eb, axis, sep_e, inside, mid))
    faces_a = sa.face_normals.shape[1]
    face_sep = np.concatenate([sep_a, sep_b], axis=1)  # (m, F_a + F_b), padded counts
    normals = np.concatenate([sa.face_normals[ia], -rotate(rot, sb.face_normals[ib])], axis=1)
    max_sep = face_sep.max(axis=1)
    np.maximum.at(max_sep, rows, sep_e)
    colliding = max_sep <= CONTACT_TOL_REL * scale
    overlap = -face_sep
    best = overlap.min(axis=1)
    face = np.argmax(overlap <= (best + TIE_TOL_REL * scale)[:, None], axis=1)
    normal = normals[np.arange(m), face]
    wins, item = _edge_winner(rows, axis, sep_e, inside, normal, best, scale)
    wins &= colliding
    kind = np.where(wins, EDGE, np.where(face < faces_a, FACE_A, FACE_B))
    own_face = np.where(face < faces_a, face, face - faces_a)
    choice = AxisChoice(colliding, kind, np.where(wins, -1, own_face),
                        np.where(colliding, np.maximum(best, 0.0), 0.0), normal,
                        np.full(m, -1), np.full(m, -1), np.zeros((m, 3)), scale)
    if wins.any():
        at = item[wins]
        choice.depth[wins] = np.maximum(-sep_e[at], 0.0)
        choice.normal[wins], choice.edge_point[wins] = axis[at], mid[at]
        choice.edge_a[wins], choice.edge_b[wins] = ea[at], eb[at]
    _separated_normals(choice, face_sep, normals, rows, sep_e, axis)
    return choice


def _edge_winner(rows, axis, sep_e, inside, normal, best, scale):
    """(m,) whether an edge axis wins (rules 1-3 of the module docstring) and its item."""
    m = len(best)
    banned = np.abs(dot(axis, normal[rows])) > FACE_AXIS_COS_TOL  # rule 1
    bar = best.copy()  # a banned axis competes as the face, with its own overlap
    np.minimum.at(bar, rows[banned], -sep_e[banned])
    allowed = np.flatnonzero(~banned)
    pick = _first_per_row(rows[allowed], -sep_e[allowed], m)
    item = np.where(pick >= 0, allowed[np.maximum(pick, 0)] if len(allowed) else 0, -1)
    has = item >= 0
    if not has.any():
        return has, item
    safe = np.where(has, item, item[has][0])
    wins = has & inside[safe] & (-sep_e[safe] < bar - DEPTH_GAIN_TOL_REL * scale)
    return wins, safe


def _separated_normals(choice: AxisChoice, face_sep, normals, rows, sep_e, axis) -> None:
    """Separated rows: the normal of the most separating axis (A towards B)."""
    apart = ~choice.colliding
    if not apart.any():
        return
    m = len(apart)
    face_top = face_sep.max(axis=1)
    normal = normals[np.arange(m), face_sep.argmax(axis=1)]
    top = _first_per_row(rows, -sep_e, m)
    edge_better = top >= 0
    edge_better[edge_better] = sep_e[top[edge_better]] > face_top[edge_better]
    normal[edge_better] = axis[top[edge_better]]
    choice.normal = np.where(apart[:, None], normal, choice.normal)
