"""The centre of pressure of one face contact, in plain Python floats (the N = 1 path).

Same stages, tolerances and order of operations as :mod:`models.pressure`, whose docstring
explains the rule and the geometry (the apex, its edges, the 4 depth slots of each face).
Fan triangles of zero area are skipped: the batch path adds them, but their terms are exactly
0, so both paths agree to the last bit (tested).
"""
from __future__ import annotations

import math

from models.pressure import PRESSURE_FLOOR_REL


def _sign(x: float) -> float:
    return 1.0 if x >= 0.0 else -1.0


def apex_edges(h_ref, h_inc, rot_ri, t_ri, ref_axis, tau):
    """The incident box's deepest vertex and its three edges (batch: ``apex_edges``).

    Parameters are :func:`models.exact_scalar.reference_view`'s (reference frame x, y, z) and
    the reference axis. Returns ``(apex, edges, ref_sign)``: ``apex`` ``(u, w, p0)``, and per
    incident axis j ``(d_u, d_w, g)``: the edge from the apex and its pressure drop (metres).
    """
    axis, u, w = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    ref_sign = _sign(t_ri[axis])
    along, at_u, at_w = t_ri[axis], t_ri[u], t_ri[w]
    row_x, row_u, row_w = rot_ri[axis], rot_ri[u], rot_ri[w]
    edges = []
    for j in range(3):
        reach = -_sign(ref_sign * row_x[j]) * h_inc[j]
        x, y, z = reach * row_x[j], reach * row_u[j], reach * row_w[j]
        along, at_u, at_w = along + x, at_u + y, at_w + z
        edges.append((-2.0 * y, -2.0 * z, 2.0 * abs(x)))
    apex = (at_u, at_w, (h_ref[axis] - ref_sign * along) + tau)
    return apex, edges, ref_sign


def _fraction(level, drop):
    """Fraction of an edge that stays at ``p >= 0`` (batch: ``_fraction``)."""
    if level < 0.0:
        return 0.0
    return level / drop if level < drop else 1.0


def depth_slots(p0, edges):
    """The three front faces clipped to ``p >= 0``: per face k, 4 ``(u, w, p)`` slots after
    the apex, u and w relative to it (batch: ``depth_slots``)."""
    cuts, levels = [], []
    for d_u, d_w, drop in edges:
        fraction = _fraction(p0, drop)
        cuts.append((fraction * d_u, fraction * d_w))
        levels.append(p0 - drop)
    faces = []
    for k in range(3):
        p, q = (k + 1) % 3, (k + 2) % 3
        (cut_pu, cut_pw), (cut_qu, cut_qw) = cuts[p], cuts[q]
        level_p, level_q = levels[p], levels[q]
        (d_pu, d_pw, drop_p), (d_qu, d_qw, drop_q) = edges[p], edges[q]
        mu, nu = _fraction(level_p, drop_q), _fraction(level_q, drop_p)
        far = max(level_p - drop_q, 0.0)
        faces.append(((cut_pu, cut_pw, max(level_p, 0.0)),
                      (cut_pu + mu * d_qu, cut_pw + mu * d_qw, far),
                      (cut_qu + nu * d_pu, cut_qw + nu * d_pw, far),
                      (cut_qu, cut_qw, max(level_q, 0.0))))
    return faces


def _crossing(poly, s, start, coordinate, value):
    """The plane's crossing on the edge from ``start`` to the next point (see the batch)."""
    end = (start + 1) % len(poly)
    s_a, s_b = s[start], s[end]
    lam = s_a / (s_a - s_b)  # in [0, 1]: the two are on different sides
    a, b = poly[start], poly[end]
    point = [a[0] + lam * (b[0] - a[0]), a[1] + lam * (b[1] - a[1]), a[2] + lam * (b[2] - a[2])]
    point[coordinate] = value
    return point


def clip(poly, s, coordinate, value):
    """One Sutherland-Hodgman step by ``s >= 0``, in the batch path's output order."""
    k = len(poly)
    inside = [x >= 0.0 for x in s]
    count = sum(inside)
    if count == k or count == 0:
        return poly if count else []
    entry = next(i for i in range(k) if not inside[i] and inside[(i + 1) % k])
    walk = [(entry + j) % k for j in range(1, k)]
    leave = next(x for x in walk if inside[x] and not inside[(x + 1) % k])
    enter_point = _crossing(poly, s, entry, coordinate, value)
    leave_point = _crossing(poly, s, leave, coordinate, value)
    return [enter_point] + [poly[x] if inside[x] else leave_point for x in walk] + [leave_point]


def clip_sides(poly, half_u, half_w):
    """A polygon (absolute ``[u, w, p]`` points) clipped to the four side planes in the batch
    path's order; [] if nothing is left (batch: ``clip_polygons``)."""
    for coordinate, bound, upper in ((0, half_u, True), (0, half_u, False), (1, half_w, True),
                                     (1, half_w, False)):
        if upper:
            poly = clip(poly, [bound - v[coordinate] for v in poly], coordinate, bound)
        else:
            poly = clip(poly, [bound + v[coordinate] for v in poly], coordinate, -bound)
        if not poly:
            return poly
    return poly


def fan_moments(apex, rest):
    """``(int p, int u p, int w p, int p^2)`` over a polygon, fan from ``apex`` ``(u, w, p)``;
    ``rest``: the other points as ``(u, w, p)``, u and w relative to the apex."""
    a_p = apex[2]
    sum_p = sum_u = sum_w = sum_pp = 0.0
    b_u, b_w, b_p = rest[0]
    for c_u, c_w, c_p in rest[1:]:
        area = abs(b_u * c_w - b_w * c_u)  # twice the area
        if area != 0.0:
            total = (a_p + b_p) + c_p
            with_b, with_c = total + b_p, total + c_p
            sum_p = sum_p + area * total
            sum_u = sum_u + area * (b_u * with_b + c_u * with_c)
            sum_w = sum_w + area * (b_w * with_b + c_w * with_c)
            sum_pp = sum_pp + area * (a_p * total + b_p * (b_p + c_p) + c_p * c_p)
        b_u, b_w, b_p = c_u, c_w, c_p
    moment_p = sum_p / 6.0
    return (moment_p, apex[0] * moment_p + sum_u / 24.0, apex[1] * moment_p + sum_w / 24.0,
            sum_pp / 12.0)


def _near_rim(apex, faces, half_u, half_w):
    """Whether any slot may reach past a side plane (batch: ``_side_clipped``'s ``near``)."""
    first_0, first_1, first_2 = faces[0][0], faces[1][0], faces[2][0]
    extent_u = (abs(first_0[0]) + abs(first_1[0])) + abs(first_2[0])
    extent_w = (abs(first_0[1]) + abs(first_1[1])) + abs(first_2[1])
    a_u, a_w = apex[0], apex[1]
    return (a_u + extent_u > half_u or a_u - extent_u < -half_u
            or a_w + extent_w > half_w or a_w - extent_w < -half_w)


def _clipped_face(apex, slots, half_u, half_w):
    """Moments and largest pressure of a face that reaches past a side plane, clipped to them
    (batch: ``_side_clipped``); None if it does not reach past one, ``(None, -inf)`` if
    nothing is left."""
    a_u, a_w, p0 = apex
    us, ws = [v[0] for v in slots], [v[1] for v in slots]
    if not (a_u + max(0.0, *us) > half_u or a_u + min(0.0, *us) < -half_u
            or a_w + max(0.0, *ws) > half_w or a_w + min(0.0, *ws) < -half_w):
        return None
    poly = clip_sides([list(apex)] + [[a_u + u, a_w + w, p] for u, w, p in slots],
                      half_u, half_w)
    if not poly:
        return None, -math.inf
    first = poly[0]
    rest = [(v[0] - first[0], v[1] - first[1], v[2]) for v in poly[1:]]
    return fan_moments(first, rest), max(v[2] for v in poly)


def centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale, fallback):
    """The impact point of one face contact in the reference frame, as ``[x, y, z]``, and the
    deepest point of its region below the reference plane (metres; None if the region is empty).

    ``fallback`` ``(along, u, w)``: the point where the region is empty (see the batch).
    """
    tau = PRESSURE_FLOOR_REL * scale
    axis, u, w = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    apex, edges, ref_sign = apex_edges(h_ref, h_inc, rot_ri, t_ri, ref_axis, tau)
    point = [0.0, 0.0, 0.0]
    p0 = apex[2]
    if not p0 > 0.0:  # the batch's sums are all <= 0 there
        point[axis], point[u], point[w] = fallback
        return point, None
    half_u, half_w = h_ref[u], h_ref[w]
    faces = depth_slots(p0, edges)
    near = _near_rim(apex, faces, half_u, half_w)
    weight = along_u = along_w = square = 0.0
    deepest = -math.inf
    for slots in faces:
        clipped = _clipped_face(apex, slots, half_u, half_w) if near else None
        if clipped is None:
            moments, largest = fan_moments(apex, slots), p0
        elif clipped[0] is None:
            continue
        else:
            moments, largest = clipped
        weight, along_u = weight + moments[0], along_u + moments[1]
        along_w, square = along_w + moments[2], square + moments[3]
        deepest = max(deepest, largest)
    if not weight > 0.0:
        point[axis], point[u], point[w] = fallback
        return point, None
    offset = max(0.5 * (square / weight) - 0.5 * tau, 0.0)
    point[axis] = ref_sign * h_ref[axis] - ref_sign * offset
    point[u], point[w] = along_u / weight, along_w / weight
    return point, max(deepest - tau, 0.0)
