"""Separating-axis test of two convex polyhedra, compiled: :func:`sat_rows` tests a range of
rows (each one pair of hulls at one relative pose; one row: ``stop = start + 1``) in the
calling thread; :func:`choose_axis` answers m rows (poses of one pair of hulls, or rows naming
their hulls in two :class:`~impactnet.models.compound.hull_stack.HullTable`; a row's answer
does not depend on the others).

Frame: A's body frame. Hull A's vertices are as built (:mod:`impactnet.models.compound.hull`);
hull B's are ``y = R v + t``. Candidate axes:

* A's face normals: separation ``min_B (n . y) - h`` (B's vertices against A's plane);
* B's face normals, the same the other way round;
* for every edge of A and edge of B whose Gauss-map arcs cross (the pair spans a face of the
  Minkowski difference; Gregorius, "The Separating Axis Test between Convex Polyhedra", GDC
  2013): the cross product of the two edges, oriented away from A, separation
  ``u . (q0 - p0)`` between the two edges' lines.

The hulls touch iff no axis separates them by more than :data:`CONTACT_TOL_REL` of the pair's
scale (the sum of both hulls' largest half-extents). The contact axis follows the box solver's
tie rule (:mod:`impactnet.models.box.tolerances`) with the same constants:

1. the face axis of least overlap, ties within :data:`TIE_TOL_REL` to the lowest index (A's
   faces before B's);
2. an edge axis within :data:`FACE_AXIS_ANGLE_TOL` of that face's normal never wins: it
   competes as that face, with its own overlap where that is smaller (the face's depth stays
   its own);
3. another edge axis wins only if shallower by more than :data:`DEPTH_GAIN_TOL_REL`, and only
   where the closest points of its two edges lie inside both edges
   (:data:`EDGE_INSIDE_TOL_REL`); of equally shallow edge axes the lowest (A's edge, B's edge)
   competes.

An edge pair changes nothing unless it separates more than every face axis (``face_top``, the
largest face separation) and more than the best edge pair less the depth gain: rule 2 needs
the winner shallower than the best face by the gain, a banned pair lowers the bar only where
it is within the gain of the winner, and the colliding test and a separated row's normal take
the largest separation (ties to the lowest pair). So the search only has to evaluate every
crossing pair that may separate more than ``max(face_top, best - gain)``; the answer is then
the one of the test on every pair, bit for bit.

Search (chosen by measurement; two 256-sided heads meet with about n^2 / 2 crossing arc pairs,
all of which the NumPy solver's scan of every pair evaluated):

* Face axes: ``min_B (n . y)`` is B's support along ``-n``, found by steepest descent over B's
  vertex graph (:func:`_separations`), starting from the support of the face's parent in a
  spanning tree of nearest face normals (a step or two away). A linear function's sublevel
  sets on a convex polytope's vertex graph are connected, so a local minimum whose neighbours
  all lie above it by more than the rounding of the values is the minimum; where a neighbour
  lies within :data:`FLOOD_TOL_REL` of it (a face parallel to the searched direction: a
  many-sided head standing on a plate), every vertex within that of it is visited and the
  smallest value kept (:func:`_flood`). The value is the same floating-point expression as a
  scan of every vertex, so the minimum has the same bits. Hulls not convex to
  :data:`~impactnet.models.compound.hull_stack.CLIMB_FLAT_TOL_REL` of their size are scanned.
* Edge axes: each hull's Gauss-map arcs sit in a binary tree of spherical caps
  (:mod:`impactnet.models.compound.hull_stack`); the two trees are walked together (B's caps
  turned by ``-R``, the child of larger bound first) and a pair of nodes is dropped when its
  caps do not meet (the caps are widened far above rounding, so every pair the exact crossing
  test accepts is visited), or when neither node's bound of an edge separation
  (:func:`_edge_bounds`), plus the rounding of a computed separation (:func:`_prune_margin`),
  exceeds the bar. The rounding grows as ``1 / sin`` of the angle between the two edges: the
  nodes' cones of edge directions bound that angle where the smallest margin (any usable pair)
  is too wide. Small node pairs (:data:`PAIR_BLOCK` edge pairs) are tested pair by pair, each
  against its own edges' bounds first, then the NumPy solver's crossing test. Ties among the
  crossing pairs are broken by the lowest (A's edge, B's edge) whatever the walk's order, as
  the row-major scan did. Hulls not convex enough are walked on caps alone.

Measured (one thread, medians, ``python -m tests.models.compound.convex_bench``, four runs;
head: the spreader's twistlock head, a stadium frustum; random poses near contact; the
separating-axis test and the contact, per pair in a batch of 256, at 8 / 32 / 128 / 256
sides): the NumPy solver 43-62 / 172-200 / 600-710 / 1,250-1,610 us on a plate and 91-102 /
780-900 / 10,000-11,400 / 35,500-45,600 us on a head; the kernels 3.9-4.3 / 9.6-10.6 / 27-35 /
48-53 us on a plate and 5.1-5.2 / 14-17 / 56-59 / 130-135 us on a head. Two 256-sided heads
resting on each other (the walk's and the face clip's worst case) cost about 510 us.

Every expression sums its terms in the order of the NumPy solver it replaces (``x0 y0 + x1 y1
+ x2 y2``), so the answers keep their bits. Kernels read a table's arrays out of their tuple
once per call (each read costs a reference count, an atomic operation the kernel threads would
contend for), and hot loops call no function that takes an array.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from impactnet.models.box.tolerances import (
    CONTACT_TOL_REL,
    DEPTH_GAIN_TOL_REL,
    EDGE_INSIDE_TOL_REL,
    EDGE_SKEW_TOL_REL,
    FACE_AXIS_COS_TOL,
    TIE_TOL_REL,
)
from impactnet.models.compiled import PARALLEL_MIN_ROWS, chunks, jit, launch, numba, parallel_jit
from impactnet.models.compound.hull import Hull
from impactnet.models.compound.hull_stack import HullTable, stack_hulls

prange = numba.prange  # numba comes through models.compiled (its cache folder is set first)

#: Kinds of contact axis.
FACE_A, FACE_B, EDGE = 0, 1, 2
#: A support search's local minimum is the minimum unless a neighbour lies within this (x the
#: searched points' reach plus |t|, metres) of it: 4500 ulps of the magnitudes the values are
#: computed from, above their rounding and the hulls' own flatness
#: (:data:`~impactnet.models.compound.hull_stack.CLIMB_FLAT_TOL_REL`) with a wide margin.
FLOOD_TOL_REL = 1e-12
#: Rounding of a computed edge separation (:func:`_prune_margin`), the part that grows as the
#: two edges turn parallel: the unit axis of edges at an angle of sine s is off by at most
#: about 9 ulps / s (the cross product of two rounded differences, its normalisation), which
#: moves the separation by that times the distance between the edges' ends (dimensionless:
#: 16 ulps).
SEP_ROUNDING = 16 * float(np.finfo(float).eps)
#: The rest of the edge-axis search's margin (x the coordinates' magnitude and the arcs'
#: conditioning, metres; :func:`_prune_margin`): the rounding of the coordinates, of the dot
#: products and of the bounds themselves, 4500 ulps of their magnitudes.
PRUNE_TOL_REL = 1e-12
#: Node pairs of the tree walk with at most this many edge pairs are not opened: their pairs
#: are tested one by one (each against its own edges' bounds first), fewer steps than the walk
#: down to the leaves. Measured on two 256-sided heads resting on each other (the walk's
#: worst case): 32 - 64 cost least.
PAIR_BLOCK = 16
#: Pairs of tree nodes waiting in the walk of the two Gauss-map trees (at most the two trees'
#: depths together: 2 x 12 levels for 16,000 edges).
TREE_STACK = 128
#: Work items (rows x table entries of the pair) per chunk of rows: about 10 ms of work between
#: two checkpoints of the calling context's work limit (measured: 65 rows of two 256-sided
#: heads, 3,800 rows of two boxes).
CHUNK_ITEMS = 200_000


class SatWork(NamedTuple):
    """Scratch of one thread's rows (sized by the largest hulls of the two tables)."""

    y: np.ndarray  # (V, 3) B's vertices in A's frame
    normals_b: np.ndarray  # (F, 3) B's face normals in A's frame
    offsets_b: np.ndarray  # (F,) their plane offsets
    sep_a: np.ndarray  # (F,) separations along A's faces
    sep_b: np.ndarray  # (F,) along B's faces
    support_a: np.ndarray  # (F,) int64: B's support vertex of each of A's faces
    support_b: np.ndarray  # (F,) int64: A's support vertex of each of B's faces
    gap_a: np.ndarray  # (F,) the second smallest value of a support search less the smallest
    gap_b: np.ndarray  # (F,)
    mark: np.ndarray  # (V,) int64 visit stamps of the flood
    queue: np.ndarray  # (V,) int64
    stamp: np.ndarray  # (1,) int64 the last stamp used
    arcs_b: np.ndarray  # (E, 3) B's arc normals in A's frame
    nodes_b: np.ndarray  # (N, 3) B's Gauss-map caps' centres, turned by -R
    dirs_b: np.ndarray  # (N, 3) B's nodes' edge-direction axes, turned by R
    bound_a: np.ndarray  # (N,) A's nodes' bounds of an edge separation (m)
    bound_b: np.ndarray  # (N,) B's
    edge_bound_a: np.ndarray  # (E,) A's edges' bounds (m)
    edge_bound_b: np.ndarray  # (E,) B's
    stack: np.ndarray  # (TREE_STACK, 2) int64 node pairs of the tree walk


@jit
def sat_work(vertices, faces, edges, nodes):
    """A :class:`SatWork` for hulls of at most these counts."""
    return SatWork(np.empty((vertices, 3)), np.empty((faces, 3)), np.empty(faces),
                   np.empty(faces), np.empty(faces), np.zeros(faces, np.int64),
                   np.zeros(faces, np.int64), np.empty(faces), np.empty(faces),
                   np.zeros(vertices, np.int64),
                   np.empty(vertices, np.int64), np.zeros(1, np.int64), np.empty((edges, 3)),
                   np.empty((nodes, 3)), np.empty((nodes, 3)), np.empty(nodes),
                   np.empty(nodes), np.empty(edges), np.empty(edges),
                   np.empty((TREE_STACK, 2), np.int64))


def work_counts(table_a: HullTable, table_b: HullTable) -> tuple[int, int, int, int]:
    """(vertices, faces, edges, nodes): the largest hull counts of two tables."""
    a, b = table_a.widest, table_b.widest
    return (max(a["V"], b["V"]), max(a["F"], b["F"]), max(a["E"], b["E"]),
            max(a["N"], b["N"]))


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


@jit
def maximum(a, b):
    """``np.maximum`` of two floats (the first on ties, so -0.0 stays -0.0 as there)."""
    return a if a >= b else b


@jit
def minimum(a, b):
    """``np.minimum`` of two floats."""
    return a if a <= b else b


# --- Stage 1: B in A's frame --------------------------------------------------------------------


# --- Stage 2: face axes -------------------------------------------------------------------------


@jit
def _flood(points, base, starts, neighbours, vbase, start, value, d0, d1, d2, slack, mark,
           queue, stamp):
    """The smallest ``p . d`` over the vertices connected to ``start`` through vertices within
    ``slack`` of its value ``value`` (module docstring): (value, vertex). ``points[base + v]``
    is vertex v, its neighbours ``neighbours[starts[vbase + v]:starts[vbase + v + 1]]``;
    ``mark``, ``queue`` and the last mark ``stamp[0]`` are scratch."""
    stamp[0] += 1
    now = stamp[0]
    limit = value + slack
    best, arg = value, start
    mark[start] = now
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        u = queue[head]
        head += 1
        for k in range(starts[vbase + u], starts[vbase + u + 1]):
            x = neighbours[k]
            if mark[x] == now:
                continue
            mark[x] = now
            w = points[base + x, 0] * d0 + points[base + x, 1] * d1 + points[base + x, 2] * d2
            if w <= limit:
                queue[tail] = x
                tail += 1
                if w < best:
                    best, arg = w, x
    return best, arg


@jit
def _separations(points, base, count, climb, starts, neighbours, vbase, order, parent, first,
                 nf, normals, nbase, offsets, obase, support, sep, gap, slack, mark, queue,
                 stamp):
    """``sep[f] = min_v (p_v . n_f) - h_f``, ``support[f]`` its vertex and ``gap[f]`` the
    second smallest value less the smallest (0 on ties) for the nf faces of one hull against
    the vertices ``points[base:base + count]`` of the other (module docstring): faces in the
    order of their tree (``order[first + k]``, ``parent[first + k]``), normals
    ``normals[nbase + f]``, offsets ``offsets[obase + f]``. A scan of every vertex for the
    first face and where the other hull may not be climbed on, else a climb from the parent's
    support (the second smallest vertex neighbours the smallest); ties of a local minimum
    flooded (:func:`_flood`)."""
    for k in range(nf):
        f, up = order[first + k], parent[first + k]
        d0, d1, d2 = normals[nbase + f, 0], normals[nbase + f, 1], normals[nbase + f, 2]
        if not climb or up < 0:
            value, second, v = np.inf, np.inf, 0
            for q in range(count):
                w = (points[base + q, 0] * d0 + points[base + q, 1] * d1
                     + points[base + q, 2] * d2)
                if w < value:
                    value, second, v = w, value, q
                elif w < second:
                    second = w
            gap[f] = second - value
        else:
            v = support[up]
            value = points[base + v, 0] * d0 + points[base + v, 1] * d1 + points[base + v, 2] * d2
            while True:
                lowest, step = np.inf, -1
                for s in range(starts[vbase + v], starts[vbase + v + 1]):
                    u = neighbours[s]
                    w = (points[base + u, 0] * d0 + points[base + u, 1] * d1
                         + points[base + u, 2] * d2)
                    if w < lowest:
                        lowest, step = w, u
                if lowest < value:
                    v, value = step, lowest
                    continue
                gap[f] = lowest - value
                if lowest <= value + slack:
                    value, v = _flood(points, base, starts, neighbours, vbase, v, value, d0, d1,
                                      d2, slack, mark, queue, stamp)
                    gap[f] = 0.0
                break
        support[f] = v
        sep[f] = value - offsets[obase + f]


@jit
def _face_choice(sep_a, nfa, sep_b, nfb, scale):
    """(best overlap, largest separation, tie-rule face, most separating face) over A's faces
    then B's (indices into that concatenation)."""
    top, top_face = -np.inf, 0
    for f in range(nfa + nfb):
        sep = sep_a[f] if f < nfa else sep_b[f - nfa]
        if sep > top:
            top, top_face = sep, f
    best = -top
    bar = best + TIE_TOL_REL * scale
    for f in range(nfa + nfb):
        sep = sep_a[f] if f < nfa else sep_b[f - nfa]
        if -sep <= bar:
            return best, top, f, top_face
    return best, top, 0, top_face


@jit
def _face_normal(normals, fa0, normals_b, nfa, face):
    """The unit normal of face ``face`` of the concatenation (A's from ``fa0``, then B's in A's
    frame), from A towards B."""
    if face < nfa:
        return normals[fa0 + face, 0], normals[fa0 + face, 1], normals[fa0 + face, 2]
    g = face - nfa
    return -normals_b[g, 0], -normals_b[g, 1], -normals_b[g, 2]


# --- Stage 3: edge axes -------------------------------------------------------------------------


@jit
def _edge_geometry(p0, p1, q0, q1, centre, scale):
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
def _edge_closest(p0, da, q0, db, la, lb, scale):
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
def _arc_bound(c1, c2, c3, c4, angle, low, high):
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
def _edge_bounds(edge_faces, e0, angle, sep, support, gap, slack, reach, points, pbase,
                 normals, nbase, offsets, obase, tree_edge, node_first, node_count, node_left,
                 node_right, n0, nn, cut, edge_bound, bound):
    """``edge_bound[e]`` a bound of the separation of any crossing pair of the hull's own edge
    e, ``bound[node]`` the largest over the node's edges (module docstring): one hull's edges
    from ``e0`` (faces its own; arcs' ``angle`` rows of
    :attr:`~impactnet.models.compound.hull_stack.HullArrays.edge_angle`; separations ``sep``,
    supports ``support`` and gaps ``gap`` of its faces on the other hull's
    ``points[pbase + v]``, rounded to ``slack``, ``reach`` the other hull's radius; normals
    ``normals[nbase + f]``, offsets ``offsets[obase + f]``) and tree nodes ``n0 .. n0 + nn``
    (children after parents). Bounds at most ``cut`` are not refined.

    Along an arc of angle theta from face a to face b, ``u . (y_a - p0)`` is
    ``L1 = (c1 sin(theta - phi) + c2 sin(phi)) / sin(theta)`` (``c1`` face a's separation,
    ``c2 = b . y_a - h_b``); the same ``L2`` with ``y_b``. Coarse: each weight lies between its
    share of the angle and ``theta / sin(theta)`` times it, so ``L`` is at most the larger of
    its ends, the positive ones times that. Refined (:func:`_arc_bound`): no other vertex's
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
                value = _arc_bound(c1, c2, c3, c4, angle[e], low, high)
            edge_bound[own] = value
            top = max(top, value)
        bound[node] = top


@jit
def _prune_margin(sine, near, far):
    """The rounding of a computed edge separation (m) for edges at an angle of sine at least
    ``sine`` (``near``: the largest distance between the edges' ends, ``far``: the
    coordinates' magnitude and the arcs' conditioning): :data:`SEP_ROUNDING` x ``near / sine``
    plus :data:`PRUNE_TOL_REL` x ``far``."""
    return SEP_ROUNDING * near / sine + PRUNE_TOL_REL * far


@jit
def _pair_sine(dir_a, e, dir_b, g, rot, k):
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
def _better(sep, ea, eb, top, top_a, top_b):
    """(sep, ea, eb) ranks before the current top: larger separation, then the lowest pair."""
    return top_a < 0 or sep > top or (sep == top and (ea < top_a or (ea == top_a and eb < top_b)))


class AxisRows(NamedTuple):
    """The answer arrays of :func:`sat_rows` (fields of :class:`AxisChoice`)."""

    colliding: np.ndarray  # (m,) bool
    kind: np.ndarray  # (m,) int64
    face: np.ndarray  # (m,) int64
    depth: np.ndarray  # (m,)
    normal: np.ndarray  # (m, 3)
    edge_a: np.ndarray  # (m,) int64
    edge_b: np.ndarray  # (m,) int64
    edge_point: np.ndarray  # (m, 3)
    scale: np.ndarray  # (m,)


@jit
def axis_rows(m):
    """:class:`AxisRows` for m rows."""
    return AxisRows(np.zeros(m, np.bool_), np.zeros(m, np.int64), np.zeros(m, np.int64),
                    np.zeros(m), np.zeros((m, 3)), np.zeros(m, np.int64), np.zeros(m, np.int64),
                    np.zeros((m, 3)), np.zeros(m))


@jit
def turn(src, s0, n, rot, k, t, shifted, sign, dst):
    """``dst[i] = t[k] + R src[s0 + i]`` where ``shifted``, else ``sign R src[s0 + i]``
    (i < n, ``R = rot[k]``), each component ``(r0 x0 + r1 x1) + r2 x2`` as the NumPy solver
    rotated."""
    r00, r01, r02 = rot[k, 0, 0], rot[k, 0, 1], rot[k, 0, 2]
    r10, r11, r12 = rot[k, 1, 0], rot[k, 1, 1], rot[k, 1, 2]
    r20, r21, r22 = rot[k, 2, 0], rot[k, 2, 1], rot[k, 2, 2]
    for i in range(n):
        x0, x1, x2 = src[s0 + i, 0], src[s0 + i, 1], src[s0 + i, 2]
        v0 = r00 * x0 + r01 * x1 + r02 * x2
        v1 = r10 * x0 + r11 * x1 + r12 * x2
        v2 = r20 * x0 + r21 * x1 + r22 * x2
        if shifted:
            dst[i, 0], dst[i, 1], dst[i, 2] = t[k, 0] + v0, t[k, 1] + v1, t[k, 2] + v2
        else:
            dst[i, 0], dst[i, 1], dst[i, 2] = sign * v0, sign * v1, sign * v2


# --- The rows -----------------------------------------------------------------------------------


@jit
def sat_rows(ta, ia, tb, ib, t, rot, out, base, start, stop, work):
    """The separating-axis test of rows start..stop (module docstring): row k of hull
    ``ia[k]`` of table ``ta`` (A, :attr:`HullTable.arrays`) and hull ``ib[k]`` of ``tb`` (B)
    at B's pose ``t[k]`` (3,), ``rot[k]`` (3, 3) in A's body frame, written to row
    ``k - base`` of ``out`` (:class:`AxisRows`). ``work``: the thread's :class:`SatWork`
    (:func:`sat_work` with :func:`work_counts` of the tables). One row: ``stop = start + 1``.
    """
    # The tables' arrays, once per call (a tuple's array read in a loop costs a reference
    # count, an atomic operation that the kernel threads would contend for).
    vertices, normals, offsets = ta.vertices, ta.face_normals, ta.face_offsets
    edges_a, faces_a, arcs_a = ta.edges, ta.edge_faces, ta.edge_arcs
    radius_a, cos_a, sin_a, centre_a, dir_a = (ta.node_radius, ta.node_cos, ta.node_sin,
                                               ta.node_centre, ta.node_dir)
    cone_cos_a, cone_sin_a = ta.node_cone_cos, ta.node_cone_sin
    left_a, right_a, first_a, count_a, tree_a = (ta.node_left, ta.node_right, ta.node_first,
                                                 ta.node_count, ta.tree_edge)
    vstart_a, fstart_a, estart_a, nstart_a = (ta.vertex_start, ta.face_start, ta.edge_start,
                                              ta.node_start)
    vertices_b, normals_b0, offsets_b0, arcs_b0 = (tb.vertices, tb.face_normals,
                                                   tb.face_offsets, tb.edge_arcs)
    centres_b0, dirs_b0 = tb.node_centre, tb.node_dir
    edges_b, faces_b = tb.edges, tb.edge_faces
    radius_b, cos_b, sin_b = tb.node_radius, tb.node_cos, tb.node_sin
    cone_cos_b, cone_sin_b = tb.node_cone_cos, tb.node_cone_sin
    left_b, right_b, first_b, count_b, tree_b = (tb.node_left, tb.node_right, tb.node_first,
                                                 tb.node_count, tb.tree_edge)
    vstart_b, fstart_b, estart_b, nstart_b = (tb.vertex_start, tb.face_start, tb.edge_start,
                                              tb.node_start)
    y, normals_b, offsets_b, arcs_b = work.y, work.normals_b, work.offsets_b, work.arcs_b
    nodes_b, dirs_b, stack = work.nodes_b, work.dirs_b, work.stack
    sep_a, sep_b, bound_a, bound_b = work.sep_a, work.sep_b, work.bound_a, work.bound_b
    edge_bound_a, edge_bound_b = work.edge_bound_a, work.edge_bound_b
    dir_edge_a, dir_edge_b = ta.edge_dir, tb.edge_dir
    support_a, support_b, gap_a, gap_b = work.support_a, work.support_b, work.gap_a, work.gap_b
    mark, queue, stamp = work.mark, work.queue, work.stamp
    colliding_out, kind_out, face_out, depth_out = out.colliding, out.kind, out.face, out.depth
    normal_out, edge_a_out, edge_b_out, point_out = (out.normal, out.edge_a, out.edge_b,
                                                     out.edge_point)
    scale_out = out.scale
    for k in range(start, stop):
        ha, hb = ia[k], ib[k]
        va0, fa0, ea0, na0 = vstart_a[ha], fstart_a[ha], estart_a[ha], nstart_a[ha]
        vb0, fb0, eb0, nb0 = vstart_b[hb], fstart_b[hb], estart_b[hb], nstart_b[hb]
        nva, nfa = vstart_a[ha + 1] - va0, fstart_a[ha + 1] - fa0
        nvb, nfb = vstart_b[hb + 1] - vb0, fstart_b[hb + 1] - fb0
        scale = ta.half_extent[ha] + tb.half_extent[hb]
        centre = (ta.centre[ha, 0], ta.centre[ha, 1], ta.centre[ha, 2])
        t0, t1, t2 = t[k, 0], t[k, 1], t[k, 2]
        magnitude = (abs(t0) + abs(t1) + abs(t2)) + ta.reach[ha] + tb.reach[hb]

        # Stage 1: B in A's frame. Vertices t + R v, face normals R n with offsets
        # h + (R n) . t, arc normals R (n1 x n0), Gauss-map caps' centres -R c, edge-direction
        # axes R d.
        turn(vertices_b, vb0, nvb, rot, k, t, True, 1.0, y)
        turn(normals_b0, fb0, nfb, rot, k, t, False, 1.0, normals_b)
        for g in range(nfb):
            offsets_b[g] = offsets_b0[fb0 + g] + (normals_b[g, 0] * t0 + normals_b[g, 1] * t1
                                                  + normals_b[g, 2] * t2)
        turn(arcs_b0, eb0, estart_b[hb + 1] - eb0, rot, k, t, False, 1.0, arcs_b)
        turn(centres_b0, nb0, nstart_b[hb + 1] - nb0, rot, k, t, False, -1.0, nodes_b)
        turn(dirs_b0, nb0, nstart_b[hb + 1] - nb0, rot, k, t, False, 1.0, dirs_b)

        # Stage 2: face axes. A's faces against B's vertices, B's against A's (module
        # docstring), then the tie rule's face and the largest separation.
        _separations(y, 0, nvb, tb.climb[hb], tb.adjacency_start, tb.adjacency_vertex, vb0,
                     ta.face_order, ta.face_parent, fa0, nfa, normals, fa0, offsets, fa0,
                     support_a, sep_a, gap_a,
                     FLOOD_TOL_REL * ((abs(t0) + abs(t1) + abs(t2)) + tb.reach[hb]), mark,
                     queue, stamp)
        _separations(vertices, va0, nva, ta.climb[ha], ta.adjacency_start, ta.adjacency_vertex,
                     va0, tb.face_order, tb.face_parent, fb0, nfb, normals_b, 0, offsets_b, 0,
                     support_b, sep_b, gap_b, FLOOD_TOL_REL * ta.reach[ha], mark, queue, stamp)
        best, face_top, face, top_face = _face_choice(sep_a, nfa, sep_b, nfb, scale)
        normal = _face_normal(normals, fa0, normals_b, nfa, face)

        # Stage 3a: the margins (any usable pair: its edges' sine above EDGE_SKEW_TOL_REL x
        # scale / the longest edge; the best case: perpendicular edges), and the bounds of an
        # edge separation on both trees' edges and nodes (they serve where both hulls are
        # convex; those below the faces by the first margin stay coarse).
        bounded = ta.convex[ha] and tb.convex[hb]
        gap = 0.0
        for i in range(3):
            d = centre[i] - (t[k, i] + (rot[k, i, 0] * tb.centre[hb, 0]
                                        + rot[k, i, 1] * tb.centre[hb, 1]
                                        + rot[k, i, 2] * tb.centre[hb, 2]))
            gap += d * d
        near = math.sqrt(gap) + ta.radius[ha] + tb.radius[hb]
        far = (magnitude + near * (1.0 / ta.arc_min_sin[ha] + 1.0 / tb.arc_min_sin[hb])
               + 4.0 * (ta.flat[ha] + tb.flat[hb]) / PRUNE_TOL_REL)
        any_margin = _prune_margin(EDGE_SKEW_TOL_REL * scale
                                   / max(ta.longest_edge[ha], tb.longest_edge[hb]), near, far)
        best_margin = _prune_margin(1.0, near, far)
        gain = DEPTH_GAIN_TOL_REL * scale
        slack = FLOOD_TOL_REL * magnitude
        cut = face_top - any_margin
        _edge_bounds(faces_a, ea0, ta.edge_angle, sep_a, support_a, gap_a, slack,
                     tb.radius[hb], y, 0, normals, fa0, offsets, fa0, tree_a, first_a, count_a,
                     left_a, right_a, na0, nstart_a[ha + 1] - na0, cut, edge_bound_a, bound_a)
        _edge_bounds(faces_b, eb0, tb.edge_angle, sep_b, support_b, gap_b, slack,
                     ta.radius[ha], vertices, va0, normals_b, 0, offsets_b, 0, tree_b, first_b,
                     count_b, left_b, right_b, nb0, nstart_b[hb + 1] - nb0, cut, edge_bound_b,
                     bound_b)

        # Stage 3b: the two trees walked together. A pair of nodes is dropped where its caps
        # do not meet, or where no pair of its edges separates more than the faces, or than
        # the best pair found less the depth gain (module docstring); at two small nodes
        # (PAIR_BLOCK) every pair of edges gets its own bound, then the NumPy solver's crossing
        # test. Tracked: the largest separation and its pair (lowest on ties), the largest of
        # the pairs banned by rule 1, the largest of the others and its pair.
        top, top_a, top_b = -np.inf, -1, -1
        free, free_a, free_b = -np.inf, -1, -1
        banned = -np.inf
        stack[0, 0], stack[0, 1] = 0, 0
        size = 1
        while size > 0:
            size -= 1
            i, j = stack[size, 0], stack[size, 1]
            gi, gj = na0 + i, nb0 + j
            if radius_a[gi] + radius_b[gj] < math.pi and (
                    centre_a[gi, 0] * nodes_b[j, 0] + centre_a[gi, 1] * nodes_b[j, 1]
                    + centre_a[gi, 2] * nodes_b[j, 2]) < (cos_a[gi] * cos_b[gj]
                                                          - sin_a[gi] * sin_b[gj]):
                continue  # the caps are apart: no arc crosses
            bound = min(bound_a[i], bound_b[j])
            if bound == -np.inf:
                continue  # arcs that cross nothing
            bar = max(face_top, top - gain)
            if bounded and bound + any_margin <= bar:
                continue
            if bounded and bound + best_margin <= bar:  # unless the edges may turn parallel
                cosine = abs(dir_a[gi, 0] * dirs_b[j, 0] + dir_a[gi, 1] * dirs_b[j, 1]
                             + dir_a[gi, 2] * dirs_b[j, 2])
                cone_cos = cone_cos_a[gi] * cone_cos_b[gj] - cone_sin_a[gi] * cone_sin_b[gj]
                cone_sin = cone_sin_a[gi] * cone_cos_b[gj] + cone_cos_a[gi] * cone_sin_b[gj]
                if cone_cos > 0.0 and cosine < cone_cos:  # the directions' cones are apart
                    sine = math.sqrt(1.0 - cosine * cosine) * cone_cos - cosine * cone_sin
                    if sine > 0.0 and bound + _prune_margin(sine, near, far) <= bar:
                        continue
            leaf_a, leaf_b = left_a[gi] < 0, left_b[gj] < 0
            if not (leaf_a and leaf_b) and count_a[gi] * count_b[gj] > PAIR_BLOCK:
                # open the wider cap, the child of larger bound first
                if leaf_b or (not leaf_a and radius_a[gi] >= radius_b[gj]):
                    near_child, far_child = left_a[gi], right_a[gi]
                    if bound_a[near_child] > bound_a[far_child]:
                        near_child, far_child = far_child, near_child
                    stack[size, 0], stack[size, 1] = near_child, j
                    stack[size + 1, 0], stack[size + 1, 1] = far_child, j
                else:
                    near_child, far_child = left_b[gj], right_b[gj]
                    if bound_b[near_child] > bound_b[far_child]:
                        near_child, far_child = far_child, near_child
                    stack[size, 0], stack[size, 1] = i, near_child
                    stack[size + 1, 0], stack[size + 1, 1] = i, far_child
                size += 2
                continue
            for s in range(first_a[gi], first_a[gi] + count_a[gi]):
                ea = tree_a[s]
                e = ea0 + ea
                fa, fb = fa0 + faces_a[e, 0], fa0 + faces_a[e, 1]
                x0, x1, x2 = arcs_a[e, 0], arcs_a[e, 1], arcs_a[e, 2]
                pa, pb = va0 + edges_a[e, 0], va0 + edges_a[e, 1]
                for r in range(first_b[gj], first_b[gj] + count_b[gj]):
                    eb = tree_b[r]
                    # the pair's own bound, as the nodes' (its edges' sine from their
                    # directions, less a trace for their rounding)
                    bound = min(edge_bound_a[ea], edge_bound_b[eb])
                    bar = max(face_top, top - gain)
                    if bound == -np.inf or (bounded and bound + any_margin <= bar):
                        continue
                    if bounded and bound + best_margin <= bar:
                        sine = _pair_sine(dir_edge_a, e, dir_edge_b, eb0 + eb, rot, k) - 1e-12
                        if sine > 0.0 and bound + _prune_margin(sine, near, far) <= bar:
                            continue
                    # the arcs cross (the NumPy solver's test: c = -R n0, d = -R n1 of B's
                    # faces, a, b of A's, arcs b x a and d x c = R (n1 x n0))
                    gc, gd = faces_b[eb0 + eb, 0], faces_b[eb0 + eb, 1]
                    cba = ((-normals_b[gc, 0]) * x0 + (-normals_b[gc, 1]) * x1
                           + (-normals_b[gc, 2]) * x2)
                    dba = ((-normals_b[gd, 0]) * x0 + (-normals_b[gd, 1]) * x1
                           + (-normals_b[gd, 2]) * x2)
                    if not cba * dba < 0.0:
                        continue
                    adc = (normals[fa, 0] * arcs_b[eb, 0] + normals[fa, 1] * arcs_b[eb, 1]
                           + normals[fa, 2] * arcs_b[eb, 2])
                    bdc = (normals[fb, 0] * arcs_b[eb, 0] + normals[fb, 1] * arcs_b[eb, 1]
                           + normals[fb, 2] * arcs_b[eb, 2])
                    if not (adc * bdc < 0.0 and cba * bdc > 0.0):
                        continue
                    qa, qb = edges_b[eb0 + eb, 0], edges_b[eb0 + eb, 1]
                    usable, axis, sep, _, _, _, _ = _edge_geometry(
                        (vertices[pa, 0], vertices[pa, 1], vertices[pa, 2]),
                        (vertices[pb, 0], vertices[pb, 1], vertices[pb, 2]),
                        (y[qa, 0], y[qa, 1], y[qa, 2]), (y[qb, 0], y[qb, 1], y[qb, 2]), centre,
                        scale)
                    if not usable:
                        continue
                    if _better(sep, ea, eb, top, top_a, top_b):
                        top, top_a, top_b = sep, ea, eb
                    if abs(axis[0] * normal[0] + axis[1] * normal[1]
                           + axis[2] * normal[2]) > FACE_AXIS_COS_TOL:
                        banned = maximum(banned, sep)
                    elif _better(sep, ea, eb, free, free_a, free_b):
                        free, free_a, free_b = sep, ea, eb

        # Stage 4: the tie rule (module docstring). Separated: the most separating axis.
        colliding = maximum(face_top, top) <= CONTACT_TOL_REL * scale
        kind = FACE_A if face < nfa else FACE_B
        own = face if face < nfa else face - nfa
        depth = maximum(best, 0.0) if colliding else 0.0
        edge_a = edge_b = -1
        point = (0.0, 0.0, 0.0)
        pick_a, pick_b = (top_a, top_b) if not colliding else (free_a, free_b)
        axis, sep = (0.0, 0.0, 0.0), 0.0
        p0 = q0 = da = db = (0.0, 0.0, 0.0)
        la = lb = 1.0
        if pick_a >= 0:
            e, g = ea0 + pick_a, eb0 + pick_b
            pa, pb = va0 + edges_a[e, 0], va0 + edges_a[e, 1]
            qa, qb = edges_b[g, 0], edges_b[g, 1]
            p0 = (vertices[pa, 0], vertices[pa, 1], vertices[pa, 2])
            q0 = (y[qa, 0], y[qa, 1], y[qa, 2])
            _, axis, sep, da, db, la, lb = _edge_geometry(
                p0, (vertices[pb, 0], vertices[pb, 1], vertices[pb, 2]), q0,
                (y[qb, 0], y[qb, 1], y[qb, 2]), centre, scale)
        if not colliding:
            normal = _face_normal(normals, fa0, normals_b, nfa, top_face)
            if pick_a >= 0 and top > face_top:
                normal = axis
        elif pick_a >= 0:  # rules 2 and 3 for the shallowest edge axis outside the band
            inside, middle = _edge_closest(p0, da, q0, db, la, lb, scale)
            if inside and -sep < minimum(best, -banned) - DEPTH_GAIN_TOL_REL * scale:
                kind, own, depth = EDGE, -1, maximum(-sep, 0.0)
                normal, point, edge_a, edge_b = axis, middle, free_a, free_b
        row = k - base
        colliding_out[row], kind_out[row], face_out[row] = colliding, kind, own
        depth_out[row], edge_a_out[row], edge_b_out[row] = depth, edge_a, edge_b
        scale_out[row] = scale
        for i in range(3):
            normal_out[row, i], point_out[row, i] = normal[i], point[i]


@parallel_jit
def _sat_rows_parallel(ta, ia, tb, ib, t, rot, out, start, stop, counts, blocks):
    """:func:`sat_rows` over the kernel threads, ``blocks`` blocks of rows, a scratch each."""
    n = stop - start
    for b in prange(blocks):
        work = sat_work(counts[0], counts[1], counts[2], counts[3])
        sat_rows(ta, ia, tb, ib, t, rot, out, 0, start + b * n // blocks,
                 start + (b + 1) * n // blocks, work)


@jit
def _sat_rows_serial(ta, ia, tb, ib, t, rot, out, start, stop, work):
    """:func:`sat_rows` in this thread, rows written at their own index."""
    sat_rows(ta, ia, tb, ib, t, rot, out, 0, start, stop, work)


def blocks_of(rows: int) -> int:
    """Blocks of rows of a parallel launch: a few per thread (rows differ in cost)."""
    return max(1, min(rows, 8 * numba.get_num_threads()))


def stacked(hulls: Hull | HullTable, index, m: int) -> tuple[HullTable, np.ndarray]:
    """(table, row index (m,)) of a hull (every row) or of a table and its rows' indices."""
    if isinstance(hulls, Hull):
        return stack_hulls((hulls,)), np.zeros(m, np.int64)
    return hulls, np.ascontiguousarray(index, np.int64)


def chunk_rows(table_a: HullTable, table_b: HullTable) -> int:
    """Rows per chunk of a call on these tables (:data:`CHUNK_ITEMS`)."""
    v, f, e, _ = work_counts(table_a, table_b)
    return max(1, CHUNK_ITEMS // (2 * (v + f + e)))


def run_rows(kernel, parallel_kernel, make_work, m: int, step: int, args: tuple,
             counts) -> None:
    """Rows 0..m of a row kernel (``kernel(*args, start, stop, work)``) in chunks of ``step``
    rows, the calling context's work limit checked between chunks: in this thread below
    :data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` rows (one ``make_work(*counts)``),
    else ``parallel_kernel(*args, start, stop, counts, blocks)`` over the kernel threads, one
    launch at a time."""
    if m < PARALLEL_MIN_ROWS:
        work = make_work(*counts) if m else None
        for start, stop in chunks(m, step):
            kernel(*args, start, stop, work)
        return
    counts = np.asarray(counts, np.int64)
    for start, stop in chunks(m, step):
        launch(parallel_kernel, *args, start, stop, counts, blocks_of(stop - start))


def choose_axis(hull_a: Hull | HullTable, hull_b: Hull | HullTable, t: np.ndarray,
                rot: np.ndarray, index_a=None, index_b=None) -> AxisChoice:
    """The contact axis of m rows (module docstring).

    Parameters
    ----------
    hull_a, hull_b : Hull or HullTable
        The parts, each in its body's frame: one hull for every row, or a table whose hull of
        row i is ``index_a[i]`` (``index_b[i]``).
    t : ndarray, shape (m, 3)
        B's body origin in A's body frame (metres).
    rot : ndarray, shape (m, 3, 3)
        B's body rotation in A's body frame.
    index_a, index_b : array_like of int, shape (m,), optional
        Each row's hull in a table.
    """
    m = len(t)
    ta, ia = stacked(hull_a, index_a, m)
    tb, ib = stacked(hull_b, index_b, m)
    out = axis_rows(m)
    args = (ta.arrays, ia, tb.arrays, ib, np.ascontiguousarray(t, np.float64),
            np.ascontiguousarray(rot, np.float64), out)
    run_rows(_sat_rows_serial, _sat_rows_parallel, sat_work, m, chunk_rows(ta, tb), args,
             work_counts(ta, tb))
    return AxisChoice(*out)
