"""The centre of pressure of one face contact, in plain Python floats (the N = 1 path).

Same stages, tolerances and order of operations as :mod:`impactnet.models.box.pressure`, whose
docstring
explains the rule and the geometry (the apex, its edges, the 4 depth slots of each face).
Fan triangles of zero area are skipped: the batch path adds them, but their terms are exactly
0, so both paths agree to the last bit (tested).
"""
from __future__ import annotations

import math

from impactnet.models.box.pressure import PRESSURE_FLOOR_REL


def apex_edges(h_ref, h_inc, rot_ri, t_ri, ref_axis, tau):
    """The incident box's deepest vertex and its three edges (batch: ``apex_edges``).

    Parameters are :func:`impactnet.models.box.exact_one.reference_view`'s (reference frame x, y, z)
    and
    the reference axis. Returns ``(apex, edges, ref_sign)``: ``apex`` ``(u, w, p0)``, and per
    incident axis j ``(d_u, d_w, g)``: the edge from the apex and its pressure drop (metres).
    """
    axis, u, w = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    along, at_u, at_w = t_ri[axis], t_ri[u], t_ri[w]
    ref_sign = 1.0 if along >= 0.0 else -1.0
    edges = []
    for x, y, z, half in zip(rot_ri[axis], rot_ri[u], rot_ri[w], h_inc):
        reach = -half if ref_sign * x >= 0.0 else half  # towards the reference face
        x, y, z = reach * x, reach * y, reach * z
        along, at_u, at_w = along + x, at_u + y, at_w + z
        edges.append((-2.0 * y, -2.0 * z, 2.0 * abs(x)))
    return (at_u, at_w, (h_ref[axis] - ref_sign * along) + tau), edges, ref_sign


#: The in-plane axes (p, q) of incident faces 0, 1, 2.
_FACE_AXES = ((1, 2), (2, 0), (0, 1))


def depth_slots(p0, edges):
    """The three front faces clipped to ``p >= 0`` (batch: ``depth_slots``), for ``p0 > 0``.

    Returns ``(faces, extent_u, extent_w)``: per face, its slots after the apex as ``(u, w,
    p)``, u and w relative to the apex, and the sums of the faces' first slots' ``|u|`` and
    ``|w|`` (batch: ``_side_clipped``). A slot that repeats its neighbour (batch: ``mu`` or
    ``nu`` = 0, where the apex's neighbour is outside) is left out: it only adds triangles of
    zero area.
    """
    firsts, levels = [], []
    for d_u, d_w, drop in edges:
        fraction, level = (p0 / drop if p0 < drop else 1.0), p0 - drop
        firsts.append((fraction * d_u, fraction * d_w, level if level > 0.0 else 0.0))
        levels.append(level)
    (u_0, w_0, _), (u_1, w_1, _), (u_2, w_2, _) = firsts  # faces 2, 0, 1 start there
    extent_u = (abs(u_1) + abs(u_2)) + abs(u_0)
    extent_w = (abs(w_1) + abs(w_2)) + abs(w_0)
    faces = []
    for p, q in _FACE_AXES:
        first, last = firsts[p], firsts[q]
        level_p, level_q = levels[p], levels[q]
        if level_p < 0.0 and level_q < 0.0:
            faces.append((first, last))
            continue
        (d_pu, d_pw, drop_p), (d_qu, d_qw, drop_q) = edges[p], edges[q]
        far = level_p - drop_q
        far = far if far > 0.0 else 0.0
        slots = [first]
        if level_p >= 0.0:
            mu = level_p / drop_q if level_p < drop_q else 1.0
            slots.append((first[0] + mu * d_qu, first[1] + mu * d_qw, far))
        if level_q >= 0.0:
            nu = level_q / drop_p if level_q < drop_p else 1.0
            slots.append((last[0] + nu * d_pu, last[1] + nu * d_pw, far))
        slots.append(last)
        faces.append(slots)
    return faces, extent_u, extent_w


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
    """One Sutherland-Hodgman step by ``s >= 0``, in the batch path's output order; for a
    polygon with a point outside."""
    k = len(poly)
    inside = [x >= 0.0 for x in s]
    if not any(inside):
        return []
    entry = next(i for i in range(k) if not inside[i] and inside[(i + 1) % k])
    walk = [(entry + j) % k for j in range(1, k)]
    leave = next(x for x in walk if inside[x] and not inside[(x + 1) % k])
    enter_point = _crossing(poly, s, entry, coordinate, value)
    leave_point = _crossing(poly, s, leave, coordinate, value)
    return [enter_point] + [poly[x] if inside[x] else leave_point for x in walk] + [leave_point]


def clip_sides(poly, half_u, half_w):
    """A polygon (absolute ``(u, w, p)`` points) clipped to the four side planes in the batch
    path's order (batch: ``clip_polygons``): [] if nothing is left, ``poly`` itself if no
    point is outside."""
    for coordinate, bound, upper in ((0, half_u, True), (0, half_u, False), (1, half_w, True),
                                     (1, half_w, False)):
        values = [v[coordinate] for v in poly]
        if upper:
            if max(values) > bound:
                poly = clip(poly, [bound - x for x in values], coordinate, bound)
        elif min(values) < -bound:
            poly = clip(poly, [bound + x for x in values], coordinate, -bound)
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


def _clipped_face(apex, slots, half_u, half_w):
    """Moments and largest pressure of a face clipped to the side planes (batch:
    ``_side_clipped``): None if no point is outside them (the face reaches past none),
    ``(None, -inf)`` if nothing is left.

    No slot lies further from the apex in u or w than the first and the last together (as for
    the row, :func:`depth_slots`), so most faces need no clipping at all.
    """
    a_u, a_w, _ = apex
    (first_u, first_w, _), (last_u, last_w, _) = slots[0], slots[-1]
    reach_u, reach_w = abs(first_u) + abs(last_u), abs(first_w) + abs(last_w)
    if not (a_u + reach_u > half_u or a_u - reach_u < -half_u
            or a_w + reach_w > half_w or a_w - reach_w < -half_w):
        return None
    poly = [apex] + [(a_u + u, a_w + w, p) for u, w, p in slots]
    clipped = clip_sides(poly, half_u, half_w)
    if clipped is poly:
        return None
    if not clipped:
        return None, -math.inf
    first_u, first_w, _ = first = clipped[0]
    rest = [(v[0] - first_u, v[1] - first_w, v[2]) for v in clipped[1:]]
    return fan_moments(first, rest), max(v[2] for v in clipped)


def centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale, fallback):
    """The impact point of one face contact in the reference frame, as ``[x, y, z]``, the
    deepest point of its region below the reference plane (metres; None if the region is empty)
    and the pressure integral ``int (d + tau) dA`` (m^3, 0 if empty), as the batch.

    ``fallback`` ``(along, u, w)``: the point where the region is empty (see the batch).
    """
    tau = PRESSURE_FLOOR_REL * scale
    axis, u, w = ref_axis, (ref_axis + 1) % 3, (ref_axis + 2) % 3
    apex, edges, ref_sign = apex_edges(h_ref, h_inc, rot_ri, t_ri, ref_axis, tau)
    point = [0.0, 0.0, 0.0]
    p0 = apex[2]
    if not p0 > 0.0:  # the batch's sums are all <= 0 there
        point[axis], point[u], point[w] = fallback
        return point, None, 0.0
    half_u, half_w = h_ref[u], h_ref[w]
    faces, extent_u, extent_w = depth_slots(p0, edges)
    a_u, a_w = apex[0], apex[1]  # some slot may reach past a side plane:
    near = (a_u + extent_u > half_u or a_u - extent_u < -half_u
            or a_w + extent_w > half_w or a_w - extent_w < -half_w)
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
        return point, None, 0.0
    offset = max(0.5 * (square / weight) - 0.5 * tau, 0.0)
    point[axis] = ref_sign * h_ref[axis] - ref_sign * offset
    point[u], point[w] = along_u / weight, along_w / weight
    return point, max(deepest - tau, 0.0), weight
