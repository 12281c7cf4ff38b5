"""The separating-axis test's search of edge axes (stage 3b of
:func:`~impactnet.models.compound.convex_sat.sat_rows`): the two hulls' Gauss-map trees walked
together, and the tie rule that turns the faces' and the edges' separations into the contact axis
(stage 4). :mod:`~impactnet.models.compound.convex_sat`'s docstring gives the argument of the walk's
pruning."""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.box.tolerances import CONTACT_TOL_REL, DEPTH_GAIN_TOL_REL, FACE_AXIS_COS_TOL
from impactnet.models.compiled import jit
from impactnet.models.compound.sat_edges import (
    better,
    edge_closest,
    edge_geometry,
    pair_sine,
    prune_margin,
)
from impactnet.models.compound.sat_faces import face_normal, maximum, minimum

#: Kinds of contact axis.
FACE_A, FACE_B, EDGE = 0, 1, 2
#: Node pairs of the tree walk with at most this many edge pairs are not opened: their pairs
#: are tested one by one (each against its own edges' bounds first), fewer steps than the walk
#: down to the leaves. Measured on two 256-sided heads resting on each other (the walk's
#: worst case): 32 - 64 cost least.
PAIR_BLOCK = 16
#: Rows of two hulls with at most this many edge pairs (edges of A x edges of B) test every
#: pair (:func:`edge_walk` with ``scan``: the two roots taken as one block, nothing pruned)
#: instead of walking the trees: below it, the walk's set-up (B's caps turned, both trees'
#: bounds) costs more than the pairs it saves. Measured per row (whole contact, resting
#: poses, one thread; ``python -m tests.models.compound.convex_bench --scan``; walk / scan,
#: us): box x box (144 pairs) 6.9 / 5.1, an aperture's ring piece x box (216) 7.7 / 6.0,
#: 8-sided head x box (288) 7.2 / 6.0, head x ring (432) 9.0 / 8.4, 16-sided head x box (576)
#: 9.6 / 8.7, head16 x ring (864) 11.6 / 12.7, head32 x box (1,152) 13.1 / 14.5.
SCAN_PAIRS = 640
#: Pairs of tree nodes waiting in the walk of the two Gauss-map trees (at most the two trees'
#: depths together: 2 x 12 levels for 16,000 edges).
TREE_STACK = 128
#: An edge pair's sine from its edges' unit directions, less this for their rounding
#: (dimensionless, ~4500 ulps): the pruning margin then never undershoots.
SINE_ROUNDING = 1e-12


@jit
def edge_walk(tree_a, tree_b, nodes_b, dirs_b, edges_a, edges_b, vertices, y, normals,
              normals_b, arcs_b, bounds, row, bar_in, stop, scan):
    """Stage 3b: the two Gauss-map trees walked together (module docstring). A pair of nodes is
    dropped where its caps do not meet, or where no pair of its edges separates more than the
    faces, or than the best pair found less the depth gain; at two small nodes
    (:data:`PAIR_BLOCK`) every pair of edges gets its own bound, then the NumPy solver's
    crossing test.

    ``tree_a``, ``tree_b``: each tree's arrays (node radius, cos, sin, centre, edge-direction
    axis, cone cos, sin, left, right, first, count, tree_edge, edge_dir; A's also its
    edge_arcs), B's caps and directions turned (``nodes_b``, ``dirs_b``); ``edges_a``,
    ``edges_b``: (edges, edge_faces) of each; ``bounds``: (bound_a, bound_b, edge_bound_a,
    edge_bound_b, stack); ``row``: (na0, nb0, ea0, eb0, va0, fa0, rot, k, centre, scale,
    normal); ``bar_in``: (face_top, gain, bounded, any_margin, best_margin, near, far).
    Returns (top, top_a, top_b, free, free_a, free_b, banned): the largest separation and its
    pair (lowest on ties), the largest of the pairs not banned by rule 1 and its pair, the
    largest of the banned; the walk stops once an edge pair separates by more than ``stop``
    (metres; ``inf``: never). ``scan``: every pair of edges tested (:data:`SCAN_PAIRS`): the
    roots are one block, no cap or bound is read (B's caps, directions and both trees' bounds
    need not be set), so nothing is pruned; the answer is the walk's (the walk prunes only
    pairs that cannot change it)."""
    (radius_a, cos_a, sin_a, centre_a, dir_a, cone_cos_a, cone_sin_a, left_a, right_a, first_a,
     count_a, tree_edge_a, dir_edge_a, arcs_a) = tree_a
    (radius_b, cos_b, sin_b, cone_cos_b, cone_sin_b, left_b, right_b, first_b, count_b,
     tree_edge_b, dir_edge_b) = tree_b
    bound_a, bound_b, edge_bound_a, edge_bound_b, stack = bounds
    na0, nb0, ea0, eb0, va0, fa0, rot, k, centre, scale, normal = row
    face_top, gain, bounded, any_margin, best_margin, near, far = bar_in
    (ends_a, faces_a), (ends_b, faces_b) = edges_a, edges_b
    top, top_a, top_b = -np.inf, -1, -1
    free, free_a, free_b = -np.inf, -1, -1
    banned = -np.inf
    stack[0, 0], stack[0, 1] = 0, 0
    size = 1
    while size > 0 and not top > stop:
        size -= 1
        i, j = stack[size, 0], stack[size, 1]
        gi, gj = na0 + i, nb0 + j
        if not scan and radius_a[gi] + radius_b[gj] < math.pi and (
                centre_a[gi, 0] * nodes_b[j, 0] + centre_a[gi, 1] * nodes_b[j, 1]
                + centre_a[gi, 2] * nodes_b[j, 2]) < (cos_a[gi] * cos_b[gj]
                                                      - sin_a[gi] * sin_b[gj]):
            continue  # the caps are apart: no arc crosses
        bound = np.inf if scan else min(bound_a[i], bound_b[j])
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
                if sine > 0.0 and bound + prune_margin(sine, near, far) <= bar:
                    continue
        leaf_a, leaf_b = left_a[gi] < 0, left_b[gj] < 0
        if not scan and not (leaf_a and leaf_b) and count_a[gi] * count_b[gj] > PAIR_BLOCK:
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
            ea = tree_edge_a[s]
            e = ea0 + ea
            fa, fb = fa0 + faces_a[e, 0], fa0 + faces_a[e, 1]
            x0, x1, x2 = arcs_a[e, 0], arcs_a[e, 1], arcs_a[e, 2]
            pa, pb = va0 + ends_a[e, 0], va0 + ends_a[e, 1]
            for r in range(first_b[gj], first_b[gj] + count_b[gj]):
                eb = tree_edge_b[r]
                # the pair's own bound, as the nodes' (its edges' sine from their directions,
                # less a trace for their rounding)
                bound = np.inf if scan else min(edge_bound_a[ea], edge_bound_b[eb])
                bar = max(face_top, top - gain)
                if bound == -np.inf or (bounded and bound + any_margin <= bar):
                    continue
                if bounded and bound + best_margin <= bar:
                    sine = pair_sine(dir_edge_a, e, dir_edge_b, eb0 + eb, rot, k) - SINE_ROUNDING
                    if sine > 0.0 and bound + prune_margin(sine, near, far) <= bar:
                        continue
                # the arcs cross (the NumPy solver's test: c = -R n0, d = -R n1 of B's faces,
                # a, b of A's, arcs b x a and d x c = R (n1 x n0))
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
                qa, qb = ends_b[eb0 + eb, 0], ends_b[eb0 + eb, 1]
                usable, axis, sep, _, _, _, _ = edge_geometry(
                    (vertices[pa, 0], vertices[pa, 1], vertices[pa, 2]),
                    (vertices[pb, 0], vertices[pb, 1], vertices[pb, 2]),
                    (y[qa, 0], y[qa, 1], y[qa, 2]), (y[qb, 0], y[qb, 1], y[qb, 2]), centre,
                    scale)
                if not usable:
                    continue
                if better(sep, ea, eb, top, top_a, top_b):
                    top, top_a, top_b = sep, ea, eb
                if abs(axis[0] * normal[0] + axis[1] * normal[1]
                       + axis[2] * normal[2]) > FACE_AXIS_COS_TOL:
                    banned = maximum(banned, sep)
                elif better(sep, ea, eb, free, free_a, free_b):
                    free, free_a, free_b = sep, ea, eb
    return top, top_a, top_b, free, free_a, free_b, banned


@jit
def tie_rule(vertices, normals, normals_b, edges_a, edges_b, y, row, faces, found):
    """Stage 4: the contact axis by the tie rule (module docstring of
    :mod:`~impactnet.models.compound.convex_sat`); a separated row takes the most separating axis.
    ``faces``: (best overlap, largest face separation, tie-rule face, most separating face, A's face
    count); ``row`` and ``found`` as :func:`edge_walk` takes and returns them. Returns
    (colliding, kind, face, depth, normal (3), edge_a, edge_b, edge point (3))."""
    _, _, ea0, eb0, va0, fa0, _, _, centre, scale, normal = row
    best, face_top, face, top_face, nfa = faces
    top, top_a, top_b, free, free_a, free_b, banned = found
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
        _, axis, sep, da, db, la, lb = edge_geometry(
            p0, (vertices[pb, 0], vertices[pb, 1], vertices[pb, 2]), q0,
            (y[qb, 0], y[qb, 1], y[qb, 2]), centre, scale)
    if not colliding:
        normal = face_normal(normals, fa0, normals_b, nfa, top_face)
        if pick_a >= 0 and top > face_top:
            normal = axis
    elif pick_a >= 0:  # rules 2 and 3 for the shallowest edge axis outside the band
        inside, middle = edge_closest(p0, da, q0, db, la, lb, scale)
        if inside and -sep < minimum(best, -banned) - DEPTH_GAIN_TOL_REL * scale:
            kind, own, depth = EDGE, -1, maximum(-sep, 0.0)
            normal, point, edge_a, edge_b = axis, middle, free_a, free_b
    return colliding, kind, own, depth, normal, edge_a, edge_b, point
