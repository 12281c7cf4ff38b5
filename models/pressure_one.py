"""The centre of pressure of one face contact, in plain Python floats (the N = 1 path).

Same stages, tolerances and order of operations as :mod:`models.pressure`, whose docstring
explains the rule; polygons are lists of ``[u, w, p]`` points without the batch path's padding
(a repeated point adds exactly 0 to the fan sums, so both paths agree to the last bit, tested).
"""
from __future__ import annotations

import math

from models.pressure import PRESSURE_FLOOR_REL


def _sign(x: float) -> float:
    return 1.0 if x >= 0.0 else -1.0


def front_faces(h_ref, h_inc, rot_ri, t_ri, ref_axis, tau):
    """The incident faces that look towards the reference face, as quads.

    Parameters are :func:`models.exact_scalar.reference_view`'s (reference frame x, y, z) and
    the reference axis; returns ``(faces, ref_sign)``: faces as ``(orientation, k, quad)``
    with quad a list of 4 ``[u, w, p]`` points (metres), for the incident axes k in order.
    """
    axis, u, w = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    cyclic = (axis, u, w)
    ref_sign = _sign(t_ri[axis])
    height = h_ref[axis]
    faces = []
    for k in range(3):
        p, q = (k + 1) % 3, (k + 2) % 3
        look = ref_sign * rot_ri[axis][k]
        if look == 0.0:
            continue
        side = -_sign(look)
        axis_k = [rot_ri[c][k] for c in cyclic]
        axis_p = [rot_ri[c][p] for c in cyclic]
        axis_q = [rot_ri[c][q] for c in cyclic]
        scaled = side * h_inc[k]
        centre = [t_ri[c] + scaled * a for c, a in zip(cyclic, axis_k)]
        along_p = [h_inc[p] * a for a in axis_p]
        along_q = [h_inc[q] * a for a in axis_q]
        plus_p = [c + a for c, a in zip(centre, along_p)]
        minus_p = [c - a for c, a in zip(centre, along_p)]
        vertices = ([a + b for a, b in zip(plus_p, along_q)],
                    [a + b for a, b in zip(minus_p, along_q)],
                    [a - b for a, b in zip(minus_p, along_q)],
                    [a - b for a, b in zip(plus_p, along_q)])
        quad = [[v[1], v[2], (height - ref_sign * v[0]) + tau] for v in vertices]
        turning = axis_p[1] * axis_q[2] - axis_p[2] * axis_q[1]  # (m_p x m_q) . n
        faces.append((_sign(turning), k, quad))
    return faces, ref_sign


def _crossing(poly, s, start, coordinate, value):
    """The plane's crossing on the edge from ``start`` to the next point (see the batch)."""
    end = (start + 1) % len(poly)
    s_a, s_b = s[start], s[end]
    denominator = s_a - s_b
    lam = s_a / denominator if denominator != 0.0 else 0.0
    lam = min(max(lam, 0.0), 1.0)
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
    leave = next((x for x in walk if inside[x] and not inside[(x + 1) % k]), walk[0])
    enter_point = _crossing(poly, s, entry, coordinate, value)
    leave_point = _crossing(poly, s, leave, coordinate, value)
    return [enter_point] + [poly[x] if inside[x] else leave_point for x in walk] + [leave_point]


def depth_polygon(quad):
    """The quad clipped to ``p >= 0`` in its cyclic order, 8 points as
    :func:`models.pressure.depth_polygons`; [] if no vertex is inside."""
    inside = [v[2] >= 0.0 for v in quad]
    if not any(inside):
        return []
    crossings = []
    for i in range(4):
        a, b = quad[i], quad[(i + 1) % 4]
        denominator = a[2] - b[2]
        lam = a[2] / denominator if denominator != 0.0 else 0.0
        lam = min(max(lam, 0.0), 1.0)
        crossings.append([a[0] + lam * (b[0] - a[0]), a[1] + lam * (b[1] - a[1]), 0.0])
    leave = next((crossings[i] for i in range(4) if inside[i] and not inside[(i + 1) % 4]),
                 [0.0, 0.0, 0.0])
    poly = []
    for i in range(4):
        vertex = quad[i] if inside[i] else leave
        poly.append(vertex)
        poly.append(crossings[i] if inside[i] != inside[(i + 1) % 4] else vertex)
    return poly


def clip_face(quad, half_u, half_w):
    """A quad clipped to ``p >= 0`` and to the side planes it reaches past; [] if nothing is
    left."""
    poly = depth_polygon(quad)
    if not poly:
        return poly
    us, ws = [v[0] for v in poly], [v[1] for v in poly]
    reach = (max(us), -min(us), max(ws), -min(ws))
    for plane, (coordinate, bound, upper) in enumerate(
            ((0, half_u, True), (0, half_u, False), (1, half_w, True), (1, half_w, False))):
        if not poly:
            return poly
        if not reach[plane] > bound:
            continue
        if upper:
            poly = clip(poly, [bound - v[coordinate] for v in poly], coordinate, bound)
        else:
            poly = clip(poly, [bound + v[coordinate] for v in poly], coordinate, -bound)
    return poly


def fan_moments(poly):
    """``(int p, int u p, int w p, int p^2)`` over a polygon, fan from its first point."""
    a_u, a_w, a_p = poly[0]
    sum_p = sum_u = sum_w = sum_pp = 0.0
    b_u, b_w, b_p = poly[1][0] - a_u, poly[1][1] - a_w, poly[1][2]
    for point in poly[2:]:
        c_u, c_w, c_p = point[0] - a_u, point[1] - a_w, point[2]
        area = b_u * c_w - b_w * c_u  # twice the signed area
        total = (a_p + b_p) + c_p
        with_b, with_c = total + b_p, total + c_p
        sum_p = sum_p + area * total
        sum_u = sum_u + area * (b_u * with_b + c_u * with_c)
        sum_w = sum_w + area * (b_w * with_b + c_w * with_c)
        sum_pp = sum_pp + area * (a_p * total + b_p * (b_p + c_p) + c_p * c_p)
        b_u, b_w, b_p = c_u, c_w, c_p
    moment_p = sum_p / 6.0
    return (moment_p, a_u * moment_p + sum_u / 24.0, a_w * moment_p + sum_w / 24.0,
            sum_pp / 12.0)


def centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale, fallback):
    """The impact point of one face contact in the reference frame, as ``[x, y, z]``, and the
    deepest point of its region below the reference plane (metres; None if the region is empty).

    ``fallback`` ``(along, u, w)``: the point where the region is empty (see the batch).
    """
    tau = PRESSURE_FLOOR_REL * scale
    axis, u, w = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    faces, ref_sign = front_faces(h_ref, h_inc, rot_ri, t_ri, ref_axis, tau)
    per_face = [(0.0, 0.0, 0.0, 0.0)] * 3
    deepest = -math.inf
    for orientation, k, quad in faces:
        poly = clip_face(quad, h_ref[u], h_ref[w])
        if poly:
            per_face[k] = tuple(orientation * v for v in fan_moments(poly))
            deepest = max(deepest, max(v[2] for v in poly))
    total = [per_face[0][i] + per_face[1][i] + per_face[2][i] for i in range(4)]
    weight = total[0]
    point = [0.0, 0.0, 0.0]
    if not weight > 0.0:
        point[axis], point[u], point[w] = fallback
        return point, None
    offset = max(0.5 * (total[3] / weight) - 0.5 * tau, 0.0)
    point[axis] = ref_sign * h_ref[axis] - ref_sign * offset
    point[u], point[w] = total[1] / weight, total[2] / weight
    return point, max(deepest - tau, 0.0)
