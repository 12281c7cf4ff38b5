"""The separating-axis test's edge axes (stage 3 of
:func:`~impactnet.models.compound.convex_sat.sat_rows`): the geometry of an edge pair (its axis,
separation and closest points), the bounds of an edge's separation over its Gauss-map arc, and the
rounding margins the search
prunes with (:mod:`~impactnet.models.compound.convex_sat`'s docstring gives the argument)."""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.box.tolerances import EDGE_INSIDE_TOL_REL, EDGE_SKEW_TOL_REL
from impactnet.models.compiled import jit

#: Rounding of a computed edge separation (:func:`prune_margin`), the part that grows as the
#: two edges turn parallel: the unit axis of edges at an angle of sine s is off by at most
#: about 9 ulps / s (the cross product of two rounded differences, its normalisation), which
#: moves the separation by that times the distance between the edges' ends (dimensionless:
#: 16 ulps).
SEP_ROUNDING = 16 * float(np.finfo(float).eps)
#: The rest of the edge-axis search's margin (x the coordinates' magnitude and the arcs'
#: conditioning, metres; :func:`prune_margin`): the rounding of the coordinates, of the dot
#: products and of the bounds themselves, 4500 ulps of their magnitudes.
PRUNE_TOL_REL = 1e-12

@jit
def edge_geometry(p0, p1, q0, q1, centre, scale):
    """(usable, axis (3), separation, da (3), db (3), la, lb) of the edges p0-p1 of A and
    q0-q1 of B (tuples of 3, A's frame): the unit cross product oriented away from A's
    ``centre``, unusable where the edges are parallel to :data:`EDGE_SKEW_TOL_REL`."""
    da = (p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2])
    db = (q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2])
    a0 = da[1] * db[2] - da[2] * db[1]
    a1 = da[2] * db[0] - da[0] * db[2]
    a2 = da[0] * db[1] - da[1] * db[0]
    length = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    la = math.sqrt(da[0] * da[0] + da[1] * da[1] + da[2] * da[2])
    lb = math.sqrt(db[0] * db[0] + db[1] * db[1] + db[2] * db[2])
    usable = length > EDGE_SKEW_TOL_REL * scale * min(la, lb)
    if usable:
        a0, a1, a2 = a0 / length, a1 / length, a2 / length
        if (a0 * (p0[0] - centre[0]) + a1 * (p0[1] - centre[1])
                + a2 * (p0[2] - centre[2])) < 0.0:
            a0, a1, a2 = -a0, -a1, -a2
    sep = a0 * (q0[0] - p0[0]) + a1 * (q0[1] - p0[1]) + a2 * (q0[2] - p0[2])
    return usable, (a0, a1, a2), sep, da, db, la, lb


@jit
def edge_closest(p0, da, q0, db, la, lb, scale):
    """(inside, midpoint (3)): rule 3 on the closest points of the two edges' lines, and the
    midpoint of those points."""
    r = (p0[0] - q0[0], p0[1] - q0[1], p0[2] - q0[2])
    aa = da[0] * da[0] + da[1] * da[1] + da[2] * da[2]
    bb = db[0] * db[0] + db[1] * db[1] + db[2] * db[2]
    ab = da[0] * db[0] + da[1] * db[1] + da[2] * db[2]
    ar = da[0] * r[0] + da[1] * r[1] + da[2] * r[2]
    br = db[0] * r[0] + db[1] * r[1] + db[2] * r[2]
    denominator = aa * bb - ab * ab
    s = u = 0.0
    if denominator > 0.0:
        s = (ab * br - bb * ar) / denominator
        u = (aa * br - ab * ar) / denominator
    slack_a = EDGE_INSIDE_TOL_REL * scale / la
    slack_b = EDGE_INSIDE_TOL_REL * scale / lb
    inside = s >= -slack_a and s <= 1 + slack_a and u >= -slack_b and u <= 1 + slack_b
    middle = (0.5 * ((p0[0] + s * da[0]) + (q0[0] + u * db[0])),
              0.5 * ((p0[1] + s * da[1]) + (q0[1] + u * db[1])),
              0.5 * ((p0[2] + s * da[2]) + (q0[2] + u * db[2])))
    return inside, middle


@jit
def arc_bound(c1, c2, c3, c4, angle, low, high):
    """The largest over an arc of ``min(L1, L2)``, ``L1(phi) = (c1 sin(theta - phi) + c2
    sin(phi)) / sin(theta)`` (``L2`` with ``c3``, ``c4``), phi from ``2 atan(low)`` to
    ``theta - 2 atan(high)`` (``angle``: cos, sin, tan(theta / 2) of theta): ``-inf`` where
    that is empty. Each ``L = P cos(phi) + Q sin(phi)``; the largest of the smaller is at an
    end, at a peak of one or where the two meet, all found on unit vectors (no trigonometry)."""
    cos_t, sin_t, tan_half = angle[0], angle[1], angle[2]
    if low >= tan_half or high >= tan_half:
        return -np.inf
    p1, q1 = c1, (c2 - c1 * cos_t) / sin_t
    p2, q2 = c3, (c4 - c3 * cos_t) / sin_t
    # the ends: unit vectors at 2 atan(low) and theta - 2 atan(high)
    lx, ly = (1.0 - low * low) / (1.0 + low * low), 2.0 * low / (1.0 + low * low)
    cx, sx = (1.0 - high * high) / (1.0 + high * high), 2.0 * high / (1.0 + high * high)
    hx, hy = cos_t * cx + sin_t * sx, sin_t * cx - cos_t * sx
    if lx * hy - ly * hx <= 0.0:
        return -np.inf
    best = max(min(p1 * lx + q1 * ly, p2 * lx + q2 * ly), min(p1 * hx + q1 * hy, p2 * hx + q2 * hy))
    # the peaks and the meeting point, where inside
    for which in range(4):
        if which == 0:
            dx, dy = p1, q1
        elif which == 1:
            dx, dy = p2, q2
        elif which == 2:
            dx, dy = q2 - q1, p1 - p2
        else:
            dx, dy = q1 - q2, p2 - p1
        norm = math.sqrt(dx * dx + dy * dy)
        if norm == 0.0:
            continue
        dx, dy = dx / norm, dy / norm
        if lx * dy - ly * dx >= 0.0 and dx * hy - dy * hx >= 0.0:
            best = max(best, min(p1 * dx + q1 * dy, p2 * dx + q2 * dy))
    return best


@jit
def edge_bounds(edge_faces, e0, angle, sep, support, gap, slack, reach, points, pbase,
                 normals, nbase, offsets, obase, tree_edge, node_first, node_count, node_left,
                 node_right, n0, nn, cut, edge_bound, bound):
    """``edge_bound[e]`` a bound of the separation of any crossing pair of the hull's own edge e,
    ``bound[node]`` the largest over the node's edges (module docstring): one hull's edges from
    ``e0`` (faces its own; arcs' ``angle`` rows of
    :attr:`~impactnet.models.compound.hull_stack.HullArrays.edge_angle`; separations ``sep``,
    supports ``support`` and gaps ``gap`` of its faces on the other hull's ``points[pbase + v]``,
    rounded to ``slack``, ``reach`` the other hull's radius; normals ``normals[nbase + f]``, offsets
    ``offsets[obase + f]``) and tree nodes ``n0 .. n0 + nn`` (children after parents). Bounds at
    most ``cut`` are not refined.

    Along an arc of angle theta from face a to face b, ``u . (y_a - p0)`` is
    ``L1 = (c1 sin(theta - phi) + c2 sin(phi)) / sin(theta)`` (``c1`` face a's separation,
    ``c2 = b . y_a - h_b``); the same ``L2`` with ``y_b``. Coarse: each weight lies between its
    share of the angle and ``theta / sin(theta)`` times it, so ``L`` is at most the larger of
    its ends, the positive ones times that. Refined (:func:`arc_bound`): no other vertex's
    region of the other hull reaches within ``(gap - 2 slack) / (2 reach)`` of a face's normal
    (so no crossing lies there), and the largest of ``min(L1, L2)`` over the rest of the arc."""
    for node in range(nn - 1, -1, -1):
        g = n0 + node
        if node_left[g] >= 0:
            bound[node] = max(bound[node_left[g]], bound[node_right[g]])
            continue
        top = -np.inf
        for s in range(node_first[g], node_first[g] + node_count[g]):
            own = tree_edge[s]
            e = e0 + own
            fa, fb = edge_faces[e, 0], edge_faces[e, 1]
            ya, yb = pbase + support[fa], pbase + support[fb]
            na, nb = nbase + fa, nbase + fb
            c1 = sep[fa]
            c2 = (normals[nb, 0] * points[ya, 0] + normals[nb, 1] * points[ya, 1]
                  + normals[nb, 2] * points[ya, 2]) - offsets[obase + fb]
            c3 = (normals[na, 0] * points[yb, 0] + normals[na, 1] * points[yb, 1]
                  + normals[na, 2] * points[yb, 2]) - offsets[obase + fa]
            c4 = sep[fb]
            kappa = angle[e, 3]
            value = min(max(c1 if c1 <= 0.0 else c1 * kappa, c2 if c2 <= 0.0 else c2 * kappa),
                        max(c3 if c3 <= 0.0 else c3 * kappa, c4 if c4 <= 0.0 else c4 * kappa))
            if value > cut:  # the exclusions' tangents of half their angles, at most
                low = 0.25 * max(gap[fa] - 2.0 * slack, 0.0) / reach
                high = 0.25 * max(gap[fb] - 2.0 * slack, 0.0) / reach
                value = arc_bound(c1, c2, c3, c4, angle[e], low, high)
            edge_bound[own] = value
            top = max(top, value)
        bound[node] = top


@jit
def prune_margin(sine, near, far):
    """The rounding of a computed edge separation (m) for edges at an angle of sine at least
    ``sine`` (``near``: the largest distance between the edges' ends, ``far``: the
    coordinates' magnitude and the arcs' conditioning): :data:`SEP_ROUNDING` x ``near / sine``
    plus :data:`PRUNE_TOL_REL` x ``far``."""
    return SEP_ROUNDING * near / sine + PRUNE_TOL_REL * far


@jit
def pair_sine(dir_a, e, dir_b, g, rot, k):
    """The sine of the angle between A's edge e and B's edge g (global indices; B's direction
    turned by ``rot[k]``), from their unit directions."""
    d0, d1, d2 = dir_b[g, 0], dir_b[g, 1], dir_b[g, 2]
    b0 = rot[k, 0, 0] * d0 + rot[k, 0, 1] * d1 + rot[k, 0, 2] * d2
    b1 = rot[k, 1, 0] * d0 + rot[k, 1, 1] * d1 + rot[k, 1, 2] * d2
    b2 = rot[k, 2, 0] * d0 + rot[k, 2, 1] * d1 + rot[k, 2, 2] * d2
    c0 = dir_a[e, 1] * b2 - dir_a[e, 2] * b1
    c1 = dir_a[e, 2] * b0 - dir_a[e, 0] * b2
    c2 = dir_a[e, 0] * b1 - dir_a[e, 1] * b0
    return math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)


@jit
def better(sep, ea, eb, top, top_a, top_b):
    """(sep, ea, eb) ranks before the current top: larger separation, then the lowest pair."""
    return top_a < 0 or sep > top or (sep == top and (ea < top_a or (ea == top_a and eb < top_b)))
