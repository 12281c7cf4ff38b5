"""The separating-axis test's row kernel (:func:`sat_rows`, one range of rows in the calling
thread) and its scratch: the stages of :mod:`impactnet.models.compound.convex_sat` (its
docstring gives the argument) over rows of two hull tables."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from impactnet.models.box.tolerances import CONTACT_TOL_REL, DEPTH_GAIN_TOL_REL, EDGE_SKEW_TOL_REL
from impactnet.models.compiled import jit
from impactnet.models.compound.sat_edges import PRUNE_TOL_REL, edge_bounds, prune_margin
from impactnet.models.compound.sat_faces import (
    FLOOD_TOL_REL,
    face_choice,
    face_normal,
    separations,
    turn,
)
from impactnet.models.compound.sat_walk import (
    SCAN_PAIRS,
    TREE_STACK,
    edge_walk,
    tie_rule,
)


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
    scan: np.ndarray  # (1,) int64: rows of at most this many edge pairs scan every pair


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
                   np.empty((TREE_STACK, 2), np.int64), np.full(1, SCAN_PAIRS, np.int64))


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
def _face_stage(tables, ha, hb, t, rot, k, work, stop):
    """Stages 1 and 2 of row k: B's vertices, normals and plane offsets in A's frame
    (``t + R v``, ``R n``, ``h + (R n) . t``), then A's faces against B's vertices and B's
    against A's (module docstring). True as soon as a face separates by more than ``stop``
    (the rest unsearched)."""
    (vertices, normals, offsets, vstart_a, fstart_a, vertices_b, normals_b0, offsets_b0,
     vstart_b, fstart_b, climb_a, climb_b, reach_a, reach_b, adjacency_a, adjacency_b,
     order_a, order_b) = tables
    va0, fa0, vb0, fb0 = vstart_a[ha], fstart_a[ha], vstart_b[hb], fstart_b[hb]
    nfb = fstart_b[hb + 1] - fb0
    y, normals_b, offsets_b = work.y, work.normals_b, work.offsets_b
    turn(vertices_b, vb0, vstart_b[hb + 1] - vb0, rot, k, t, True, 1.0, y)
    turn(normals_b0, fb0, nfb, rot, k, t, False, 1.0, normals_b)
    for g in range(nfb):
        offsets_b[g] = offsets_b0[fb0 + g] + (normals_b[g, 0] * t[k, 0] + normals_b[g, 1] * t[k, 1]
                                              + normals_b[g, 2] * t[k, 2])
    spread = (abs(t[k, 0]) + abs(t[k, 1]) + abs(t[k, 2])) + reach_b[hb]
    if separations(y, 0, vstart_b[hb + 1] - vb0, climb_b[hb], adjacency_b[0], adjacency_b[1],
                   vb0, order_a[0], order_a[1], fa0, fstart_a[ha + 1] - fa0, normals, fa0,
                   offsets, fa0, work.support_a, work.sep_a, work.gap_a, FLOOD_TOL_REL * spread,
                   work.mark, work.queue, work.stamp, stop):
        return True
    return separations(vertices, va0, vstart_a[ha + 1] - va0, climb_a[ha], adjacency_a[0],
                       adjacency_a[1], va0, order_b[0], order_b[1], fb0, nfb, normals_b, 0,
                       offsets_b, 0, work.support_b, work.sep_b, work.gap_b,
                       FLOOD_TOL_REL * reach_a[ha], work.mark, work.queue, work.stamp, stop)


@jit
def _margins(hulls, ha, hb, t, rot, k, scale):
    """Stage 3a's margins: (whether both hulls are convex enough to bound, the margin of any
    usable pair: its edges' sine above EDGE_SKEW_TOL_REL x scale / the longest edge; the best
    case's: perpendicular edges; the largest distance between the edges' ends; the
    coordinates' magnitude and the arcs' conditioning), metres."""
    (centre_a, centre_b, radius_a, radius_b, sin_a, sin_b, flat_a, flat_b, longest_a,
     longest_b, convex_a, convex_b, reach_a, reach_b) = hulls
    gap = 0.0
    for i in range(3):
        d = centre_a[ha, i] - (t[k, i] + (rot[k, i, 0] * centre_b[hb, 0]
                                          + rot[k, i, 1] * centre_b[hb, 1]
                                          + rot[k, i, 2] * centre_b[hb, 2]))
        gap += d * d
    magnitude = (abs(t[k, 0]) + abs(t[k, 1]) + abs(t[k, 2])) + reach_a[ha] + reach_b[hb]
    near = math.sqrt(gap) + radius_a[ha] + radius_b[hb]
    far = (magnitude + near * (1.0 / sin_a[ha] + 1.0 / sin_b[hb])
           + 4.0 * (flat_a[ha] + flat_b[hb]) / PRUNE_TOL_REL)
    any_margin = prune_margin(EDGE_SKEW_TOL_REL * scale / max(longest_a[ha], longest_b[hb]),
                              near, far)
    return (convex_a[ha] and convex_b[hb], any_margin, prune_margin(1.0, near, far), near,
            far, magnitude)


@jit
def _walked(tables, tree_a, tree_b, edges_a, edges_b, hulls, faces, work, bounds, frame,
            row):
    """Stages 3a and 3b of a row of larger hulls: the caps' centres -R c and edge-direction
    axes R d of B turned, the margins, the bounds of an edge separation on both trees' edges
    and nodes (they serve where both hulls are convex; those below the faces by the first
    margin stay coarse), then the walk of the two trees. ``tables``: (A's and B's edge
    angles and node starts, B's caps' centres and edge-direction axes); ``bounds``: the
    walk's (:func:`edge_walk`), in ``work``; ``row``: (ha, hb, t, rot, k, scale, face_top,
    stop)."""
    ha, hb, t, rot, k, scale, face_top, stop = row
    angle_a, angle_b, nstart_a, nstart_b, centres_b0, dirs_b0 = tables
    na0, nb0, ea0, eb0, va0, fa0 = frame[0], frame[1], frame[2], frame[3], frame[4], frame[5]
    vertices, normals, offsets = faces[0], faces[1], faces[2]
    turn(centres_b0, nb0, nstart_b[hb + 1] - nb0, rot, k, t, False, -1.0, work.nodes_b)
    turn(dirs_b0, nb0, nstart_b[hb + 1] - nb0, rot, k, t, False, 1.0, work.dirs_b)
    bounded, any_margin, best_margin, near, far, magnitude = _margins(hulls, ha, hb, t, rot, k,
                                                                      scale)
    slack, cut = FLOOD_TOL_REL * magnitude, face_top - any_margin
    edge_bounds(edges_a[1], ea0, angle_a, work.sep_a, work.support_a, work.gap_a,
                slack, hulls[3][hb], work.y, 0, normals, fa0, offsets, fa0, tree_a[11],
                tree_a[9], tree_a[10], tree_a[7], tree_a[8], na0, nstart_a[ha + 1] - na0,
                cut, work.edge_bound_a, work.bound_a)
    edge_bounds(edges_b[1], eb0, angle_b, work.sep_b, work.support_b, work.gap_b,
                slack, hulls[2][ha], vertices, va0, work.normals_b, 0, work.offsets_b, 0,
                tree_b[9], tree_b[7], tree_b[8], tree_b[5], tree_b[6], nb0,
                nstart_b[hb + 1] - nb0, cut, work.edge_bound_b, work.bound_b)
    bounds = (work.bound_a, work.bound_b, work.edge_bound_a, work.edge_bound_b, work.stack)
    return edge_walk(tree_a, tree_b, work.nodes_b, work.dirs_b, edges_a, edges_b, vertices,
                     work.y, normals, work.normals_b, work.arcs_b, bounds, frame,
                     (face_top, DEPTH_GAIN_TOL_REL * scale, bounded, any_margin, best_margin,
                      near, far), stop, False)


@jit
def sat_rows(ta, ia, tb, ib, t, rot, out, base, start, stop, work, full):
    """The separating-axis test of rows start..stop (module docstring): row k of hull
    ``ia[k]`` of table ``ta`` (A, :attr:`HullTable.arrays`) and hull ``ib[k]`` of ``tb`` (B)
    at B's pose ``t[k]`` (3,), ``rot[k]`` (3, 3) in A's body frame, written to row
    ``k - base`` of ``out`` (:class:`AxisRows`); rows with ``ia[k] < 0`` are skipped.
    ``work``: the thread's :class:`SatWork` (:func:`sat_work` with :func:`work_counts` of the
    tables). One row: ``stop = start + 1``. ``full``: every row's whole answer, else a
    separated row's ``colliding`` alone (module docstring).
    """
    # The tables' arrays, once per call (a tuple's array read in a loop costs a reference
    # count, an atomic operation that the kernel threads would contend for).
    faces = (ta.vertices, ta.face_normals, ta.face_offsets, ta.vertex_start, ta.face_start,
             tb.vertices, tb.face_normals, tb.face_offsets, tb.vertex_start, tb.face_start,
             ta.climb, tb.climb, ta.reach, tb.reach, (ta.adjacency_start, ta.adjacency_vertex),
             (tb.adjacency_start, tb.adjacency_vertex), (ta.face_order, ta.face_parent),
             (tb.face_order, tb.face_parent))
    hulls = (ta.centre, tb.centre, ta.radius, tb.radius, ta.arc_min_sin, tb.arc_min_sin,
             ta.flat, tb.flat, ta.longest_edge, tb.longest_edge, ta.convex, tb.convex, ta.reach,
             tb.reach)
    tree_a = (ta.node_radius, ta.node_cos, ta.node_sin, ta.node_centre, ta.node_dir,
              ta.node_cone_cos, ta.node_cone_sin, ta.node_left, ta.node_right, ta.node_first,
              ta.node_count, ta.tree_edge, ta.edge_dir, ta.edge_arcs)
    tree_b = (tb.node_radius, tb.node_cos, tb.node_sin, tb.node_cone_cos, tb.node_cone_sin,
              tb.node_left, tb.node_right, tb.node_first, tb.node_count, tb.tree_edge,
              tb.edge_dir)
    edges_a, edges_b = (ta.edges, ta.edge_faces), (tb.edges, tb.edge_faces)
    vertices, normals = ta.vertices, ta.face_normals
    vstart_a, fstart_a, estart_a, nstart_a = (ta.vertex_start, ta.face_start, ta.edge_start,
                                              ta.node_start)
    fstart_b, estart_b, nstart_b = tb.face_start, tb.edge_start, tb.node_start
    arcs_b0, centres_b0, dirs_b0 = tb.edge_arcs, tb.node_centre, tb.node_dir
    half_a, half_b, centre_a = ta.half_extent, tb.half_extent, ta.centre
    y, normals_b = work.y, work.normals_b
    walk_tables = (ta.edge_angle, tb.edge_angle, nstart_a, nstart_b, centres_b0, dirs_b0)
    bounds = (work.bound_a, work.bound_b, work.edge_bound_a, work.edge_bound_b, work.stack)
    for k in range(start, stop):
        ha, hb = ia[k], ib[k]
        if ha < 0:
            continue
        row = k - base
        va0, fa0, ea0, na0 = vstart_a[ha], fstart_a[ha], estart_a[ha], nstart_a[ha]
        eb0, nb0 = estart_b[hb], nstart_b[hb]
        nfa, nfb = fstart_a[ha + 1] - fa0, fstart_b[hb + 1] - fstart_b[hb]
        scale = half_a[ha] + half_b[hb]
        out.scale[row] = scale
        # Stages 1 and 2: B in A's frame, the face axes; a separated row stops here unless
        # its whole answer is asked for.
        limit = np.inf if full else CONTACT_TOL_REL * scale
        if _face_stage(faces, ha, hb, t, rot, k, work, limit):
            out.colliding[row] = False
            continue
        best, face_top, face, top_face = face_choice(work.sep_a, nfa, work.sep_b, nfb, scale)
        normal = face_normal(normals, fa0, normals_b, nfa, face)
        # Stage 3a: the edge search's frame (B's arcs R (n1 x n0)); small hulls then test
        # every pair of edges (stage 3b, the walk's scan), larger ones walk their trees.
        turn(arcs_b0, eb0, estart_b[hb + 1] - eb0, rot, k, t, False, 1.0, work.arcs_b)
        frame = (na0, nb0, ea0, eb0, va0, fa0, rot, k,
                 (centre_a[ha, 0], centre_a[ha, 1], centre_a[ha, 2]), scale, normal)
        count_a, count_b = estart_a[ha + 1] - ea0, estart_b[hb + 1] - eb0
        if count_a * count_b <= work.scan[0]:
            found = edge_walk(tree_a, tree_b, work.nodes_b, work.dirs_b, edges_a, edges_b,
                              vertices, y, normals, normals_b, work.arcs_b, bounds, frame,
                              (face_top, DEPTH_GAIN_TOL_REL * scale, False, 0.0, 0.0, 0.0, 0.0),
                              limit, True)
        else:
            found = _walked(walk_tables, tree_a, tree_b, edges_a, edges_b, hulls, faces, work,
                            bounds, frame, (ha, hb, t, rot, k, scale, face_top, limit))
        # Stage 4: the tie rule.
        colliding, kind, own, depth, normal, edge_a, edge_b, point = tie_rule(
            vertices, normals, normals_b, edges_a[0], edges_b[0], y, frame,
            (best, face_top, face, top_face, nfa), found)
        out.colliding[row], out.kind[row], out.face[row] = colliding, kind, own
        out.depth[row], out.edge_a[row], out.edge_b[row] = depth, edge_a, edge_b
        for i in range(3):
            out.normal[row, i], out.edge_point[row, i] = normal[i], point[i]
