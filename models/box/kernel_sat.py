"""Stage 2 of the exact box-box solver: the separating-axis test and its tie rule, one pair.

In A's frame (:mod:`impactnet.models.box.kernel_frame`) the 15 candidate axes are A's face
normals (axis ids 0-2), B's face normals (3-5) and the cross products of A's edge direction i
with B's edge direction j (``6 + 3 i + j``). Along a unit axis u the two boxes overlap by
``r_A(u) + r_B(u) - |t . u|``; the boxes intersect iff every axis overlaps, and the axis of
least overlap gives the contact normal and depth.

Degenerate cross axes (edges within :data:`~impactnet.models.box.tolerances.EDGE_SKEW_TOL_REL`
of parallel) are skipped: for parallel edges the face axes already complete the test, and the
overlap along any direction is never below the true penetration depth, so an imprecise
near-parallel axis can only overestimate and lose; skipping it costs at most the skew times the
box size.

Tie rule between face and edge axes. A cross axis that points almost along a face normal
describes the same contact as that face (stacking with a tiny tilt: A's top edge x B's bottom
edge is within the tilt of the vertical), and its edge-edge answer (one crossing point, up to
half an edge from the overlap's centre) is ill-conditioned there. So:

1. *Angle band.* A cross axis within ``FACE_AXIS_ANGLE_TOL`` of the normal of the face axis of
   least overlap never becomes the contact axis (it still counts for separation).
2. *Depth gain.* Among the others, the shallowest cross axis wins only if it is shallower than
   the shallowest face axis by more than ``DEPTH_GAIN_TOL_REL`` times the pair's scale; a
   cross axis of rule 1 counts as that face, with its own (smaller) overlap.
3. *Real crossing.* An edge-edge contact is reported only where the closest points of the two
   supporting edges lie inside both segments (``EDGE_INSIDE_TOL_REL``); otherwise the face
   axis answers (:func:`decide`).

Among face axes within ``TIE_TOL_REL`` of the least overlap the lowest id wins (A before B,
x before y before z); there is no percentage bias.

Worst case of the rule (backed by ``tests/models/box/test_exact_tie_rule.py``). The SAT's least
overlap over the 15 axes is the true penetration depth ``c`` along the least-penetration axis
``u``. When the rule answers with a face axis ``n`` instead:

* the normal: by rule 1, a rejected ``u`` lies within ``phi = FACE_AXIS_ANGLE_TOL`` of ``n``
  itself; by rule 2 the face may win over a cross axis at any angle, but only when both are
  equally deep to ``DEPTH_GAIN_TOL_REL`` of the size (a tie);
* the depth: a face contact reports the SAT overlap along ``n`` unless the deepest point of its
  pressure region below the reference face is shallower (the incident box's deepest vertex
  hangs beyond the reference face), then that point's depth (``REGION_DEPTH_TOL_REL``,
  :mod:`impactnet.models.box.kernels`). It lies between ``c`` and the overlap along ``n``; the
  overlaps along two unit axes differ by at most ``|u - n| (rho_A + rho_B + |t|) <= 2 phi
  (rho_A + rho_B)`` (``rho``: a box's half diagonal), so the depth exceeds ``c`` by at most
  that bound, 7 cm for two 2 m cubes, and by at most 4.4e-7 of the pair's scale on 560,000
  first-contact poses of every size and orientation family (measured in the test);
* rule 3 applies only at ties: for the exact least overlap, the closest points of the crossing
  edges lie inside both edges (the nearest facet of the Minkowski difference contains the
  origin's projection).

Layout: the 15 overlaps and the 9 cross axes' sines ``|e_i x b_j|`` live in the caller's
scratch array (:data:`OVERLAPS`, :data:`SINES`); only the chosen axis is kept as a vector, and
:func:`unit_axis` recomputes it from its id with the same formulas.
"""
from __future__ import annotations

import math

from impactnet.models.box.kernel_frame import maximum, minimum, moved, sign
from impactnet.models.box.tolerances import (
    CONTACT_TOL_REL,
    DEPTH_GAIN_TOL_REL,
    EDGE_INSIDE_TOL_REL,
    EDGE_SKEW_TOL_REL,
    FACE_AXIS_COS_TOL,
    SKIPPED_AXIS_OVERLAP,
    TIE_TOL_REL,
)
from impactnet.models.compiled import jit
from impactnet.models.geometry.box_features import EDGE_BASE

#: Scratch slots (float64): the 15 overlaps (metres), then the 9 cross axes' sines.
OVERLAPS, SINES = 0, 15
#: Scratch slots this stage uses.
SAT_SCRATCH = 24


@jit
def overlaps(ha, hb, r, t, tb, scale, work):
    """The overlaps (metres) along the 15 axes into ``work[0:15]`` (+inf where a degenerate
    cross axis is skipped, negative where the axis separates) and the sines ``|e_i x b_j|`` of
    the cross axes before normalisation into ``work[15:24]``."""
    for i in range(3):  # A's face normals: ha_i + sum_j |R_ij| hb_j - |t_i|
        work[i] = (ha[i] + abs(r[3 * i]) * hb[0] + abs(r[3 * i + 1]) * hb[1]
                   + abs(r[3 * i + 2]) * hb[2] - abs(t[i]))
    for j in range(3):  # B's face normals: hb_j + sum_i |R_ij| ha_i - |(R^T t)_j|
        work[3 + j] = (hb[j] + abs(r[j]) * ha[0] + abs(r[3 + j]) * ha[1]
                       + abs(r[6 + j]) * ha[2] - abs(tb[j]))
    skew_tol = EDGE_SKEW_TOL_REL * scale
    for i in range(3):
        # e_i x b_j has components -b_j[q] at p and b_j[p] at q (p, q = i + 1, i + 2 mod 3)
        # and 0 at i; the exact zero terms are left out of every sum.
        p, q = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            r_p, r_q = r[3 * p + j], r[3 * q + j]
            sine = math.sqrt(r_p * r_p + r_q * r_q)
            work[SINES + 3 * i + j] = sine
            valid = sine * 2.0 * maximum(ha[i], hb[j]) > skew_tol
            divisor = sine if valid else 1.0
            u_p, u_q = -(r_q / divisor), r_p / divisor  # unit axis components at p and q
            radius_b = (hb[0] * abs(u_p * r[3 * p] + u_q * r[3 * q])
                        + hb[1] * abs(u_p * r[3 * p + 1] + u_q * r[3 * q + 1])
                        + hb[2] * abs(u_p * r[3 * p + 2] + u_q * r[3 * q + 2]))
            radius_a = ha[p] * abs(u_p) + ha[q] * abs(u_q)
            cross = (radius_a + radius_b) - abs(u_p * t[p] + u_q * t[q])
            work[6 + 3 * i + j] = cross if valid else SKIPPED_AXIS_OVERLAP


@jit
def near_face(r, sine, i, j, face_axis):
    """Rule 1: whether cross axis (i, j) lies within the angle band of face axis ``face_axis``.

    The unit cross axis ``u = e_i x b_j / s`` (``s = |e_i x b_j|``) has cosine ``|R[o, j]| / s``
    with A's normal ``e_a`` (a != i; o the third axis of A) and ``|R[i, o]| / s`` with B's
    normal ``b_b`` (b != j; o the third axis of B), and is perpendicular to ``e_i`` and ``b_j``
    (cosine 0: near only where s is 0 too, an axis skipped anyway).
    """
    if face_axis < 3:
        entry = 0.0 if face_axis == i else abs(r[3 * (3 - i - face_axis) + j])
    else:
        entry = 0.0 if face_axis - 3 == j else abs(r[3 * i + (3 - j - (face_axis - 3))])
    return entry >= FACE_AXIS_COS_TOL * sine


@jit
def choose_axis(work, r, scale):
    """Rules 1-2 of the tie rule on the overlaps in ``work`` (:func:`overlaps`).

    Returns
    -------
    colliding : bool
        Every axis overlaps (within ``CONTACT_TOL_REL`` of the scale).
    axis : int
        The contact axis of a colliding pair; the axis of largest separation otherwise.
    depth : float
        Overlap along the contact axis, clamped at 0 (metres); 0 if separated.
    face_axis : int
        The face axis that rule 3 falls back to where a cross axis won.
    face_depth : float
        Its overlap, clamped at 0 (metres); 0 if separated.
    """
    tie = TIE_TOL_REL * scale
    face_min = work[0]
    for k in range(1, 6):
        face_min = minimum(face_min, work[k])
    face_axis = 0
    while not work[face_axis] <= face_min + tie and face_axis < 5:
        face_axis += 1
    cross_min, cross_axis = SKIPPED_AXIS_OVERLAP, 6
    near_min, any_cross = SKIPPED_AXIS_OVERLAP, work[6]
    for c in range(9):
        over = work[6 + c]
        any_cross = minimum(any_cross, over)
        if near_face(r, work[SINES + c], c // 3, c % 3, face_axis):
            near_min = minimum(near_min, over)  # the face's own contact, through a tilt
        elif over < cross_min:
            cross_min, cross_axis = over, 6 + c
    face_bar = minimum(face_min, near_min)
    use_cross = cross_min < face_bar - DEPTH_GAIN_TOL_REL * scale
    axis = cross_axis if use_cross else face_axis
    face_depth = work[face_axis]
    chosen = cross_min if use_cross else face_depth
    colliding = minimum(face_min, any_cross) >= -CONTACT_TOL_REL * scale
    if not colliding:
        separating = 0
        if face_min <= any_cross:
            while work[separating] != face_min:
                separating += 1
        else:
            separating = 6
            while work[separating] != any_cross:
                separating += 1
        return False, separating, 0.0, face_axis, 0.0
    return True, axis, maximum(chosen, 0.0), face_axis, maximum(face_depth, 0.0)


@jit
def unit_axis(r, t, tb, axis):
    """Axis ``axis`` (0-14) recomputed with the formulas of :func:`overlaps`: the unit axis in
    A's frame (3-tuple, not oriented) and ``unit . t`` (metres). A degenerate cross axis gives
    a finite, meaningless vector."""
    if axis < 3:
        return (1.0 if axis == 0 else 0.0, 1.0 if axis == 1 else 0.0,
                1.0 if axis == 2 else 0.0), t[axis]
    if axis < 6:
        j = axis - 3
        return (r[j], r[3 + j], r[6 + j]), tb[j]
    i, j = (axis - 6) // 3, (axis - 6) % 3
    p, q = (i + 1) % 3, (i + 2) % 3
    b_p, b_q = r[3 * p + j], r[3 * q + j]
    sine = math.sqrt(b_p * b_p + b_q * b_q)
    sine = sine if sine > 0.0 else 1.0
    u_p, u_q = -(b_q / sine), b_p / sine
    projection = u_p * t[p] + u_q * t[q]
    return ((0.0 if i == 0 else (u_p if p == 0 else u_q)),
            (0.0 if i == 1 else (u_p if p == 1 else u_q)),
            (0.0 if i == 2 else (u_p if p == 2 else u_q))), projection


@jit
def oriented_normal(r, t, tb, axis):
    """Axis ``axis`` as a unit 3-tuple oriented from A towards B (ties to +), A's frame."""
    unit, projection = unit_axis(r, t, tb, axis)
    s = sign(projection)
    return (unit[0] * s, unit[1] * s, unit[2] * s)


@jit
def edge_id(axis, negative):
    """Edge id along ``axis`` from the per-axis negative signs (3-tuple of bool) of its
    centre: the signs of the two other axes j < l weigh 2 and 1."""
    j, l = (1, 2) if axis == 0 else ((0, 2) if axis == 1 else (0, 1))
    return EDGE_BASE + 4 * axis + 2 * int(negative[j]) + int(negative[l])


@jit
def edge_contact(ha, hb, r, t, scale, normal, axis):
    """Closest points of the supporting edges of a cross axis (rule 3), in A's frame.

    The supporting edge of A along +normal and of B along -normal (sides of the normal's sign,
    ties to +); the point is the midpoint of their closest points, clamped to the edges.

    Returns
    -------
    point : 3-tuple
        Midpoint of the two closest points (the mid-surface point), A's frame (metres).
    edge_a, edge_b : int
        Feature ids of the two edges.
    inside : bool
        The unclamped closest points lie inside both edges (within ``EDGE_INSIDE_TOL_REL`` of
        the scale) and the edges are not parallel.
    """
    i, j = (axis - 6) // 3, (axis - 6) % 3
    centre_a = (0.0 if i == 0 else (ha[0] if normal[0] >= 0.0 else -ha[0]),
                0.0 if i == 1 else (ha[1] if normal[1] >= 0.0 else -ha[1]),
                0.0 if i == 2 else (ha[2] if normal[2] >= 0.0 else -ha[2]))
    in_b = (r[0] * normal[0] + r[3] * normal[1] + r[6] * normal[2],
            r[1] * normal[0] + r[4] * normal[1] + r[7] * normal[2],
            r[2] * normal[0] + r[5] * normal[1] + r[8] * normal[2])
    local_b = (0.0 if j == 0 else (-hb[0] if in_b[0] >= 0.0 else hb[0]),
               0.0 if j == 1 else (-hb[1] if in_b[1] >= 0.0 else hb[1]),
               0.0 if j == 2 else (-hb[2] if in_b[2] >= 0.0 else hb[2]))
    centre_b = moved(t, r, local_b)
    dir_b = (r[j], r[3 + j], r[6 + j])
    offset = (centre_b[0] - centre_a[0], centre_b[1] - centre_a[1], centre_b[2] - centre_a[2])
    cos = dir_b[i]
    square = (dir_b[0] * dir_b[0], dir_b[1] * dir_b[1], dir_b[2] * dir_b[2])
    sine2 = (square[1] + square[2] if i == 0 else
             (square[0] + square[2] if i == 1 else square[0] + square[1]))
    proj_a = offset[i]
    proj_b = offset[0] * dir_b[0] + offset[1] * dir_b[1] + offset[2] * dir_b[2]
    safe = sine2 if sine2 > 0 else 1.0
    reach_a, reach_b = ha[i], hb[j]
    s_free, t_free = (proj_a - cos * proj_b) / safe, (cos * proj_a - proj_b) / safe
    slack = EDGE_INSIDE_TOL_REL * scale
    inside = sine2 > 0 and abs(s_free) <= reach_a + slack and abs(t_free) <= reach_b + slack
    s = minimum(maximum(s_free, -reach_a), reach_a)
    u = minimum(maximum(t_free, -reach_b), reach_b)
    point = (0.5 * (((s if i == 0 else centre_a[0]) + centre_b[0]) + u * dir_b[0]),
             0.5 * (((s if i == 1 else centre_a[1]) + centre_b[1]) + u * dir_b[1]),
             0.5 * (((s if i == 2 else centre_a[2]) + centre_b[2]) + u * dir_b[2]))
    edge_a = edge_id(i, (normal[0] < 0, normal[1] < 0, normal[2] < 0))
    edge_b = edge_id(j, (in_b[0] >= 0, in_b[1] >= 0, in_b[2] >= 0))
    return point, edge_a, edge_b, inside


@jit
def decide(ha, hb, r, t, tb, scale, work):
    """Stage 2 of one pair in A's frame: the contact axis by the tie rule (rules 1-3).

    ``work``: the caller's scratch (at least :data:`SAT_SCRATCH` float64), left holding the
    overlaps and sines (:func:`overlaps`).

    Returns
    -------
    colliding : bool
    axis : int
        0-14 (:mod:`impactnet.models.contacts`).
    depth : float
        The overlap along the axis, clamped at 0 (metres); 0 if separated.
    normal : 3-tuple
        The axis oriented from A towards B, A's frame.
    edge : bool
        An edge-edge contact (a cross axis whose edges really cross).
    point : 3-tuple
        Its point (:func:`edge_contact`), A's frame (metres); zeros otherwise.
    edge_a, edge_b : int
        Its features; -1 otherwise.
    """
    overlaps(ha, hb, r, t, tb, scale, work)
    colliding, axis, depth, face_axis, face_depth = choose_axis(work, r, scale)
    normal = oriented_normal(r, t, tb, axis)
    if colliding and axis >= 6:
        point, edge_a, edge_b, inside = edge_contact(ha, hb, r, t, scale, normal, axis)
        if inside:
            return True, axis, depth, normal, True, point, edge_a, edge_b
        # rule 3: the edges do not really cross, the face axis answers
        axis, depth = face_axis, face_depth
        normal = oriented_normal(r, t, tb, axis)
    return colliding, axis, depth, normal, False, (0.0, 0.0, 0.0), -1, -1
