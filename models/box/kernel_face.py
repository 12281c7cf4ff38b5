"""Stage 3 of the exact box-box solver: the manifold of a face contact, one pair.

The box that owns the chosen face axis is the *reference* box; the other one is the *incident*
box. Everything happens in the reference box's frame (:func:`reference_view`), in the cyclic
coordinates ``(axis, u, w)`` with ``u, w = axis + 1, axis + 2 (mod 3)``, where the reference
face is the rectangle ``|u| <= h_u, |w| <= h_w`` in the plane ``x_axis = ref_sign h_axis``.
The incident face is the incident box's face most anti-parallel to the normal
(:func:`incident_quad`).

Clip (:func:`clip_candidates`). The vertices of the intersection of the incident quad and the
reference rectangle (the Sutherland-Hodgman result) are found in closed form, among 24
candidates in this fixed order:

* 0-3: the quad's vertices inside the rectangle (snapped onto it);
* 4-7: the rectangle's corners inside the quad (a parallelogram), unless on a quad vertex
  (squared distance within ``tol^2``);
* 8-23: the crossing of quad edge e (from vertex e to e + 1) with rectangle line l (u = +h_u,
  u = -h_u, w = +h_w, w = -h_w), at index ``8 + 4 e + l``, unless at an end of either.

Coincidences within ``SNAP_TOL_REL`` of the scale are counted once, in that order of priority,
so a stack of equal boxes gives 4 points, not 8. Candidates above the reference plane (depth
below ``-tol``) are dropped; the points where the incident face crosses the reference plane
(depth 0) are not reported. The manifold is the surviving candidates, deepest first, ties in
candidate order (a stable sort), at most ``MAX_MANIFOLD_POINTS`` of them; depths are clamped at
0 and the points lie on the mid-surface (moved by half their depth towards the incident box).
Lengths compared with ``tol`` are ``sqrt(x*x + y*y)`` (as recorded, not ``hypot``). The
manifold is the contact *set*; the impact point is the centre of pressure of the whole
footprint (:mod:`impactnet.models.box.kernel_pressure`).

The incident feature (:func:`incident_feature`) is named by how many of the incident face's
vertices penetrate (depth >= ``-tol``): one vertex, two (an edge: the deepest vertex and the
next one, ties to the lower index) or three or more (the face).
"""
from __future__ import annotations

import math

from impactnet.models.box.kernel_frame import maximum, minimum, sign, transposed
from impactnet.models.box.kernel_sat import SAT_SCRATCH
from impactnet.models.box.tolerances import EDGE_WEIGHTS, QUAD_SIGNS, SNAP_TOL_REL, VERTEX_WEIGHTS
from impactnet.models.compiled import jit
from impactnet.models.contacts import MAX_MANIFOLD_POINTS
from impactnet.models.geometry.box_features import EDGE_BASE, VERTEX_BASE

#: Scratch slots (float64) of the 24 clip candidates, 4 each: u, w, depth (metres) and the
#: sort key (-depth, +inf for a dropped candidate); then the survivors, sorted, 4 each.
CANDIDATES = SAT_SCRATCH
SURVIVORS = CANDIDATES + 4 * 24
#: Scratch slots this stage uses (from 0).
FACE_SCRATCH = SURVIVORS + 4 * 24


@jit
def reference_view(ha, hb, r, t, tb, axis):
    """``(h_ref, h_inc, R_ri, t_ri)`` of a face axis (0-5): the half-extents of the reference
    box (A's for axes 0-2, B's for 3-5) and of the incident box, and the incident box's
    rotation (row-major 9-tuple) and centre (metres) in the reference box's frame."""
    if axis < 3:
        return ha, hb, r, t
    return hb, ha, transposed(r), (-tb[0], -tb[1], -tb[2])


@jit
def cyclic(v, axis):
    """The 3-tuple ``v`` in the cyclic order ``(axis, axis + 1, axis + 2)`` (mod 3)."""
    return v[axis], v[(axis + 1) % 3], v[(axis + 2) % 3]


@jit
def from_reference(axis, along, u, w):
    """A point (x, y, z) of the reference frame from its cyclic coordinates."""
    return ((along if axis == 0 else (u if axis == 2 else w)),
            (along if axis == 1 else (u if axis == 0 else w)),
            (along if axis == 2 else (u if axis == 1 else w)))


@jit
def reference_axes(rot_ri, ref_axis, k):
    """Incident axes ``k, k + 1, k + 2`` (columns) along the reference coordinates (axis, u,
    w) (rows), as a row-major 9-tuple."""
    a, b, c = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    p, q = (k + 1) % 3, (k + 2) % 3
    return (rot_ri[3 * a + k], rot_ri[3 * a + p], rot_ri[3 * a + q],
            rot_ri[3 * b + k], rot_ri[3 * b + p], rot_ri[3 * b + q],
            rot_ri[3 * c + k], rot_ri[3 * c + p], rot_ri[3 * c + q])


@jit
def incident_quad(h_inc, rot_ri, t_ri, ref_axis):
    """The incident face's vertices in the reference frame.

    Returns
    -------
    vertices : tuple of four 3-tuples
        Quad vertices in cyclic order (signs ``QUAD_SIGNS`` along the face's in-plane axes p,
        q = k + 1, k + 2), coordinates (axis, u, w), metres.
    ref_sign : float
        Side (+-1) of the reference face, facing the incident box.
    k : int
        Incident face normal axis, in the incident box's frame.
    side : float
        Incident face side (+-1) along k.
    """
    tr = cyclic(t_ri, ref_axis)
    ref_sign = sign(tr[0])
    n_inc = (ref_sign * rot_ri[3 * ref_axis], ref_sign * rot_ri[3 * ref_axis + 1],
             ref_sign * rot_ri[3 * ref_axis + 2])
    k = 1 if abs(n_inc[1]) > abs(n_inc[0]) else 0
    if abs(n_inc[2]) > maximum(abs(n_inc[0]), abs(n_inc[1])):
        k = 2
    rot = reference_axes(rot_ri, ref_axis, k)
    h_k, h_p, h_q = cyclic(h_inc, k)
    side = -sign(n_inc[k])
    centre = (tr[0] + (side * h_k) * rot[0], tr[1] + (side * h_k) * rot[3],
              tr[2] + (side * h_k) * rot[6])
    along_p = (h_p * rot[1], h_p * rot[4], h_p * rot[7])
    along_q = (h_q * rot[2], h_q * rot[5], h_q * rot[8])
    plus_p = (centre[0] + along_p[0], centre[1] + along_p[1], centre[2] + along_p[2])
    minus_p = (centre[0] - along_p[0], centre[1] - along_p[1], centre[2] - along_p[2])
    vertices = ((plus_p[0] + along_q[0], plus_p[1] + along_q[1], plus_p[2] + along_q[2]),
                (minus_p[0] + along_q[0], minus_p[1] + along_q[1], minus_p[2] + along_q[2]),
                (minus_p[0] - along_q[0], minus_p[1] - along_q[1], minus_p[2] - along_q[2]),
                (plus_p[0] - along_q[0], plus_p[1] - along_q[1], plus_p[2] - along_q[2]))
    return vertices, ref_sign, k, side


@jit
def deepest_two(depth):
    """Indices of the deepest and the second deepest of 4 depths (4-tuple), ties to the
    lower index (a stable sort's first two)."""
    first = 0
    for m in range(1, 4):
        if depth[m] > depth[first]:
            first = m
    second = 1 if first == 0 else 0
    for m in range(second + 1, 4):
        if m != first and depth[m] > depth[second]:
            second = m
    return first, second


@jit
def incident_feature(depth, k, side, tol):
    """Incident feature id and rank (1 vertex, 2 edge, 3 face) from the 4 vertex depths
    (4-tuple, metres); their sign vectors are ``side`` along k and ``QUAD_SIGNS`` along p, q.
    """
    first, second = deepest_two(depth)
    touching = 0
    for m in range(4):
        touching += depth[m] >= -tol
    p, q = (k + 1) % 3, (k + 2) % 3
    neg_k = int(side < 0)
    neg_p, neg_q = int(first == 1 or first == 2), int(first >= 2)  # QUAD_SIGNS < 0
    diff_p = neg_p != int(second == 1 or second == 2)
    diff_q = neg_q != int(second >= 2)
    if touching >= 3:
        return 2 * k + neg_k, 3
    if touching == 2:
        along = min(p, q) if (diff_p and diff_q) else (p if diff_p else q)
        return (EDGE_BASE + 4 * along + EDGE_WEIGHTS[along, k] * neg_k
                + EDGE_WEIGHTS[along, p] * neg_p + EDGE_WEIGHTS[along, q] * neg_q), 2
    return (VERTEX_BASE + VERTEX_WEIGHTS[k] * neg_k + VERTEX_WEIGHTS[p] * neg_p
            + VERTEX_WEIGHTS[q] * neg_q), 1


@jit
def _candidate(work, index, u, w, d, valid):
    """Write clip candidate ``index``: u, w, depth and its key (-depth, +inf if dropped)."""
    at = CANDIDATES + 4 * index
    work[at], work[at + 1], work[at + 2] = u, w, d
    work[at + 3] = -d if valid else math.inf


@jit
def clip_candidates(quad_u, quad_w, depth, half_u, half_w, tol, work):
    """The 24 clip candidates (module docstring) of a quad (4-tuples of its vertices' u, w and
    depths, metres, cyclic order) against the rectangle ``|u| <= half_u, |w| <= half_w``, into
    ``work`` (:data:`CANDIDATES`); ``tol`` is the snap tolerance (metres)."""
    for m in range(4):  # 0-3: quad vertices inside the rectangle, clamped onto it
        valid = (abs(quad_u[m]) <= half_u + tol and abs(quad_w[m]) <= half_w + tol
                 and depth[m] >= -tol)
        _candidate(work, m, minimum(maximum(quad_u[m], -half_u), half_u),
                   minimum(maximum(quad_w[m], -half_w), half_w), depth[m], valid)
    # 4-7: rectangle corners inside the quad (a parallelogram: centre c, half-sides a, b),
    # the depth interpolated bilinearly; a corner on a quad vertex is that vertex.
    cu = 0.25 * (quad_u[0] + quad_u[1] + quad_u[2] + quad_u[3])
    cw = 0.25 * (quad_w[0] + quad_w[1] + quad_w[2] + quad_w[3])
    a0, a1 = 0.5 * (quad_u[0] - quad_u[1]), 0.5 * (quad_w[0] - quad_w[1])
    b0, b1 = 0.5 * (quad_u[1] - quad_u[2]), 0.5 * (quad_w[1] - quad_w[2])
    det = a0 * b1 - a1 * b0
    len_a, len_b = math.sqrt(a0 * a0 + a1 * a1), math.sqrt(b0 * b0 + b1 * b1)
    d_c = 0.25 * (depth[0] + depth[1] + depth[2] + depth[3])
    d_a, d_b = 0.5 * (depth[0] - depth[1]), 0.5 * (depth[1] - depth[2])
    for m in range(4):
        corner_u, corner_w = QUAD_SIGNS[m, 0] * half_u, QUAD_SIGNS[m, 1] * half_w
        ru, rw = corner_u - cu, corner_w - cw
        alpha = (ru * b1 - rw * b0) / det
        beta = (a0 * rw - a1 * ru) / det
        d = d_c + alpha * d_a + beta * d_b
        valid = ((abs(alpha) - 1.0) * len_a <= tol and (abs(beta) - 1.0) * len_b <= tol
                 and d >= -tol)
        for v in range(4):
            gap_u, gap_w = corner_u - quad_u[v], corner_w - quad_w[v]
            valid = valid and gap_u * gap_u + gap_w * gap_w > tol * tol
        _candidate(work, 4 + m, corner_u, corner_w, d, valid)
    for e in range(4):  # 8-23: quad edge e crossing the interior of rectangle line l
        f = (e + 1) % 4
        delta_u, delta_w = quad_u[f] - quad_u[e], quad_w[f] - quad_w[e]
        d_delta = depth[f] - depth[e]
        edge_len = math.sqrt(delta_u * delta_u + delta_w * delta_w)
        for l in range(4):
            on_u = l < 2  # lines u = +-h_u cross at a given u, lines w = +-h_w at a given w
            half, other_half = (half_u, half_w) if on_u else (half_w, half_u)
            value = half if l % 2 == 0 else -half
            start, other_start = (quad_u[e], quad_w[e]) if on_u else (quad_w[e], quad_u[e])
            step, other_step = (delta_u, delta_w) if on_u else (delta_w, delta_u)
            moves = step != 0.0
            tau = (value - start) / (step if moves else 1.0)
            other = other_start + tau * other_step
            d = depth[e] + tau * d_delta
            valid = (moves and tau * edge_len > tol and (1.0 - tau) * edge_len > tol
                     and abs(other) < other_half - tol and d >= -tol)
            if on_u:
                _candidate(work, 8 + 4 * e + l, value, other, d, valid)
            else:
                _candidate(work, 8 + 4 * e + l, other, value, d, valid)


@jit
def manifold_order(work):
    """The surviving candidates, deepest first, ties in candidate order (a stable insertion
    sort), into ``work`` at :data:`SURVIVORS` (u, w, depth, key each); returns how many
    survived (the manifold keeps the first ``MAX_MANIFOLD_POINTS``)."""
    count = 0
    for c in range(24):
        key = work[CANDIDATES + 4 * c + 3]
        if key < math.inf:
            at = count
            while at > 0 and work[SURVIVORS + 4 * (at - 1) + 3] > key:
                for x in range(4):
                    work[SURVIVORS + 4 * at + x] = work[SURVIVORS + 4 * (at - 1) + x]
                at -= 1
            for x in range(4):
                work[SURVIVORS + 4 * at + x] = work[CANDIDATES + 4 * c + x]
            count += 1
    return min(count, MAX_MANIFOLD_POINTS)


@jit
def face_manifold(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale, work):
    """Clip the incident face against the reference face (stage 3).

    Parameters are :func:`reference_view`'s, the reference axis (0-2), the pair scale (metres)
    and the scratch (at least :data:`FACE_SCRATCH` float64).

    Returns
    -------
    count : int
        Manifold points, left in ``work`` at :data:`SURVIVORS` as (u, w, depth, key), deepest
        first; depths not yet clamped at 0.
    ref_sign : float
        Side (+-1) of the reference face.
    incident, rank : int
        Incident feature id and rank (1 vertex, 2 edge, 3 face).
    deepest : 3-tuple
        The incident face's deepest vertex clamped into the reference face, on the
        mid-surface, coordinates (axis, u, w): the point of a contact whose pressure region is
        empty (:func:`impactnet.models.box.kernel_pressure.centre_of_pressure`).
    """
    tol = SNAP_TOL_REL * scale
    vertices, ref_sign, k, side = incident_quad(h_inc, rot_ri, t_ri, ref_axis)
    height, half_u, half_w = cyclic(h_ref, ref_axis)
    depth = (height - ref_sign * vertices[0][0], height - ref_sign * vertices[1][0],
             height - ref_sign * vertices[2][0], height - ref_sign * vertices[3][0])
    quad_u = (vertices[0][1], vertices[1][1], vertices[2][1], vertices[3][1])
    quad_w = (vertices[0][2], vertices[1][2], vertices[2][2], vertices[3][2])
    clip_candidates(quad_u, quad_w, depth, half_u, half_w, tol, work)
    count = manifold_order(work)
    incident, rank = incident_feature(depth, k, side, tol)
    corner = vertices[deepest_two(depth)[0]]
    deepest_depth = maximum(height - ref_sign * corner[0], 0.0)
    deepest = (ref_sign * height - ref_sign * 0.5 * deepest_depth,
               minimum(maximum(corner[1], -half_u), half_u),
               minimum(maximum(corner[2], -half_w), half_w))
    return count, ref_sign, incident, rank, deepest
