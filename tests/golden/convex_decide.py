"""The convex part solver's axis decisions redone with plain NumPy, and their margins (not a
test module).

For m poses of one pair of hulls (:class:`impactnet.models.compound.hull.Hull`, each in its
body's frame; B placed by ``t`` (m, 3) and ``rot`` (m, 3, 3) in A's body frame), following
:mod:`impactnet.models.compound.convex_sat`: face separations, the edge pairs whose Gauss-map
arcs cross, contact / no contact, the face band, rule 1's angle band, rule 2's depth gain with
equal edge pairs, rule 3's real crossing, skipped parallel edges, the edge axis's orientation
and the most separating axis of a separated pose. Margins in metres, or dimensionless for
cosines. Own code (see :mod:`tests.golden.box_axes`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.golden import rule

FACE_A, FACE_B, EDGE = 0, 1, 2


@dataclass
class ConvexDecided:
    """The rule's answer for m poses of one hull pair (A's body frame)."""

    colliding: np.ndarray  # (m,) bool
    kind: np.ndarray  # (m,) FACE_A, FACE_B or EDGE
    face: np.ndarray  # (m,) the reference face (own hull's index), -1 for EDGE
    edges: np.ndarray  # (m, 2) A's and B's edge of an edge contact, else -1
    sat_depth: np.ndarray  # (m,) overlap along the axis, clamped at 0 (metres)
    scale: np.ndarray  # (m,) the pair's scale (metres)
    margins: dict  # "contact", "tie" (metres), "band" (dimensionless), (m,) each
    tie_width: np.ndarray  # (m,) metres: largest depth change between tied answers


def _edge_items(hull_a, hull_b, t, rot):
    """(row, edge_a, edge_b) of the edge pairs whose Gauss-map arcs cross."""
    a, b = (hull_a.face_normals[hull_a.edge_faces[:, k]] for k in (0, 1))
    b_x_a = np.cross(b, a)
    c, d = (-np.einsum("mij,ej->mei", rot, hull_b.face_normals[hull_b.edge_faces[:, k]])
            for k in (0, 1))
    d_x_c = np.einsum("mij,ej->mei", rot, np.cross(hull_b.face_normals[hull_b.edge_faces[:, 1]],
                                                   hull_b.face_normals[hull_b.edge_faces[:, 0]]))
    cba, dba = np.einsum("mfi,ei->mef", c, b_x_a), np.einsum("mfi,ei->mef", d, b_x_a)
    adc, bdc = np.einsum("ei,mfi->mef", a, d_x_c), np.einsum("ei,mfi->mef", b, d_x_c)
    return np.nonzero((cba * dba < 0.0) & (adc * bdc < 0.0) & (cba * bdc > 0.0))


def _edge_axes(hull_a, hull_b, y_b, scale, rows, ea, eb):
    """Per edge item: unit axis away from A (k, 3), separation (metres), usable, the skew
    test's margin, the orientation's margin, rule 3's margin (metres) and inside."""
    p0, p1 = (hull_a.vertices[hull_a.edges[ea, k]] for k in (0, 1))
    q0, q1 = (y_b[rows, hull_b.edges[eb, k]] for k in (0, 1))
    da, db = p1 - p0, q1 - q0
    axis = np.cross(da, db)
    length = np.linalg.norm(axis, axis=1)
    la, lb = np.linalg.norm(da, axis=1), np.linalg.norm(db, axis=1)
    skew_bar = rule.EDGE_SKEW_TOL_REL * scale[rows] * np.minimum(la, lb)
    usable = length > skew_bar
    axis = axis / np.where(usable, length, 1.0)[:, None]
    lean = np.einsum("ki,ki->k", axis, p0 - hull_a.vertices.mean(axis=0))
    axis = np.where((lean < 0.0)[:, None], -axis, axis)
    separation = np.einsum("ki,ki->k", axis, q0 - p0)
    r = p0 - q0
    aa, bb, ab = la * la, lb * lb, np.einsum("ki,ki->k", da, db)
    ar, br = np.einsum("ki,ki->k", da, r), np.einsum("ki,ki->k", db, r)
    den = aa * bb - ab * ab
    safe = np.where(den > 0.0, den, 1.0)
    s = np.where(den > 0.0, (ab * br - bb * ar) / safe, 0.0)
    u = np.where(den > 0.0, (aa * br - ab * ar) / safe, 0.0)
    slack = rule.EDGE_INSIDE_TOL_REL * scale[rows]
    ends = np.stack([s * la + slack, (1.0 - s) * la + slack, u * lb + slack,
                     (1.0 - u) * lb + slack], axis=1)
    inside = (ends >= 0.0).all(axis=1)
    skew = np.abs(length - skew_bar) / np.minimum(la, lb)  # metres: max(la, lb) |sin| - bar
    return axis, separation, usable, skew, np.abs(lean), np.abs(ends).min(axis=1), inside


def _first_per_row(rows, key, m):
    """(m,) the item of smallest ``key`` per row (lowest item on ties), -1 if none, and the
    next smallest key (inf if none)."""
    best, runner = np.full(m, -1), np.full(m, np.inf)
    order = np.lexsort((np.arange(len(rows)), key, rows))
    first = np.ones(len(order), bool)
    first[1:] = rows[order[1:]] != rows[order[:-1]]
    best[rows[order[first]]] = order[first]
    second = np.flatnonzero(~first)
    second = second[first[second - 1]]  # the item right after each row's first
    runner[rows[order[second]]] = key[order[second]]
    return best, runner


def _face_choice(face_sep, scale, tie_add):
    """Face axis by least overlap and the band (lowest index within TIE_TOL_REL)."""
    overlap = -face_sep
    best = overlap.min(axis=1)
    bar = best + rule.TIE_TOL_REL * scale
    face = np.argmax(overlap <= bar[:, None], axis=1)
    gap = np.abs(overlap - bar[:, None])
    index = np.arange(overlap.shape[1])[None, :]
    gap[(index > face[:, None]) | (index == overlap.argmin(axis=1)[:, None])] = np.inf
    tie_add(gap.min(axis=1), np.zeros(len(face)))
    return face, best


def _edge_rules(items, normal, best, scale, m, tie_add, band_add):
    """Rules 1-3 on the usable edge items: (wins (m,), item (m,))."""
    rows, axis, sep, skew, lean, ends, inside = items
    overlap = -sep
    cosine = np.abs(np.einsum("ki,ki->k", axis, normal[rows]))
    banned = cosine > rule.FACE_AXIS_COS_TOL
    relevant = overlap < best[rows]
    band = np.full(m, np.inf)
    np.minimum.at(band, rows[relevant], np.abs(cosine - rule.FACE_AXIS_COS_TOL)[relevant])
    band_add(band)
    bar = best.copy()
    np.minimum.at(bar, rows[banned], overlap[banned])
    allowed = np.flatnonzero(~banned)
    pick, runner = _first_per_row(rows[allowed], overlap[allowed], m)
    has = pick >= 0
    item = np.where(has, allowed[np.maximum(pick, 0)] if len(allowed) else 0, -1)
    gain = rule.DEPTH_GAIN_TOL_REL * scale
    chosen = np.where(has, overlap[np.maximum(item, 0)] if len(overlap) else 0.0, np.inf)
    tie_add(np.where(has, np.abs(chosen - bar + gain), np.inf), chosen - best)
    wins = has & (chosen < bar - gain)
    apart = np.where(wins & np.isfinite(runner), runner - np.where(wins, chosen, 0.0), np.inf)
    tie_add(apart, np.where(np.isfinite(apart), apart, 0.0))
    at = np.maximum(item, 0)
    if len(overlap):
        tie_add(np.where(wins, ends[at], np.inf), chosen - best)
        tie_add(np.where(wins, lean[at], np.inf), np.zeros(m))
        wins &= inside[at]
    return wins, item


def _separated(face_sep, rows, sep, m):
    """The most separating axis's margin (m,): the gap between the two largest separations
    over the faces and the usable edge items (metres)."""
    top = np.sort(face_sep, axis=1)[:, ::-1][:, :2]
    if face_sep.shape[1] < 2:
        top = np.concatenate([top, np.full((m, 1), -np.inf)], axis=1)
    first, runner = _first_per_row(rows, -sep, m)
    edge_top = np.where(first >= 0, sep[np.maximum(first, 0)] if len(sep) else -np.inf, -np.inf)
    values = np.concatenate([top, edge_top[:, None], -runner[:, None]], axis=1)
    values = -np.sort(-values, axis=1)
    return values[:, 0] - values[:, 1]


def convex_decide(hull_a, hull_b, t: np.ndarray, rot: np.ndarray) -> ConvexDecided:
    """The contact axis of m poses of ``hull_b`` (placed by ``t``, ``rot`` in A's body frame)
    against ``hull_a``, with the margins of every decision (module docstring)."""
    m = len(t)
    scale = np.full(m, hull_a.half_extent + hull_b.half_extent)
    y_b = t[:, None, :] + np.einsum("mij,vj->mvi", rot, hull_b.vertices)
    size = max(np.abs(hull_a.vertices).max(), 0.0)
    reach = 1.0 + np.maximum(size, np.abs(y_b).max(axis=(1, 2))) / scale
    tol = rule.DECISION_TOL_REL * reach * scale
    width, tie, band = np.zeros(m), np.full(m, np.inf), np.full(m, np.inf)

    def tie_add(margin, change):
        nonlocal tie, width
        tie = np.minimum(tie, margin)
        width = np.maximum(width, np.where(margin < tol, np.abs(np.nan_to_num(change)), 0.0))

    def band_add(margin):
        nonlocal band
        band = np.minimum(band, margin)

    sep_a = np.einsum("mvi,fi->mvf", y_b, hull_a.face_normals).min(axis=1) - hull_a.face_offsets
    n_b = np.einsum("mij,fj->mfi", rot, hull_b.face_normals)
    h_b = hull_b.face_offsets + np.einsum("mfi,mi->mf", n_b, t)
    sep_b = np.einsum("vi,mfi->mvf", hull_a.vertices, n_b).min(axis=1) - h_b
    face_sep = np.concatenate([sep_a, sep_b], axis=1)
    own = np.broadcast_to(hull_a.face_normals, (m,) + hull_a.face_normals.shape)
    normals = np.concatenate([own, -n_b], axis=1)
    rows, ea, eb = _edge_items(hull_a, hull_b, t, rot)
    axis, sep, usable, skew, lean, ends, inside = _edge_axes(hull_a, hull_b, y_b, scale, rows,
                                                             ea, eb)
    skew_m = np.full(m, np.inf)
    np.minimum.at(skew_m, rows, skew)
    tie_add(skew_m, np.zeros(m))
    rows, ea, eb, axis, sep, lean, ends, inside = (x[usable] for x in (rows, ea, eb, axis, sep,
                                                                       lean, ends, inside))
    max_sep = face_sep.max(axis=1)
    np.maximum.at(max_sep, rows, sep)
    colliding = max_sep <= rule.CONTACT_TOL_REL * scale
    contact = np.abs(max_sep - rule.CONTACT_TOL_REL * scale)
    face, best = _face_choice(face_sep, scale, tie_add)
    normal = normals[np.arange(m), face]
    wins, item = _edge_rules((rows, axis, sep, None, lean, ends, inside), normal, best, scale, m,
                             tie_add, band_add)
    wins &= colliding
    tie_add(np.where(colliding, np.inf, _separated(face_sep, rows, sep, m)), np.zeros(m))
    faces_a = hull_a.n_faces
    kind = np.where(wins, EDGE, np.where(face < faces_a, FACE_A, FACE_B))
    own = np.where(wins, -1, np.where(face < faces_a, face, face - faces_a))
    at = np.maximum(item, 0)
    edges = np.where(wins[:, None], np.stack([ea[at], eb[at]], axis=1) if len(ea) else -1, -1)
    depth = np.where(wins, -sep[at] if len(sep) else 0.0, best)
    sat_depth = np.where(colliding, np.maximum(depth, 0.0), 0.0)
    width = width + (rule.DEPTH_GAIN_TOL_REL + rule.REGION_DEPTH_TOL_REL) * scale
    return ConvexDecided(colliding, kind, own, edges, sat_depth, scale,
                         {"contact": contact, "tie": tie, "band": band, "reach": reach}, width)
