"""The impact point of a face contact: the centre of pressure of the overlap, for m pairs.

Stage 3b of the exact solver (see :mod:`models.exact`); the rule is DESIGN.md's.

The rule. The separating-axis test picks a reference face (outward normal ``n``, on the
reference box); the other box is the incident box. The contact region is the footprint, on the
reference face, of the incident box's part beyond the reference plane: every face of the
incident box that looks towards the reference face (``m . n < 0``; one per incident axis, so up
to three) is projected onto the reference plane and clipped to the reference face's four side
planes and to ``depth >= 0``. The depth ``d`` is measured along ``n`` from the reference plane;
it is linear over each projected face. Under a pressure proportional to the depth, the point
is the pressure-weighted mean of the mid-surface points ``y - n d(y) / 2``:

* tangential part: ``int y d dA / int d dA`` over the footprint (projected areas);
* offset below the plane: ``int d^2 dA / (2 int d dA)``.

Where the incident box crosses the reference plane over its whole footprint (the usual case)
the tangential part is the tangential centroid of the overlap volume inside the reference
face's prism. Because every front face takes part, the point is continuous where the incident
face changes (a corner landing first, an edge-down box through its 45-degree tie) and where the
polygon gains or loses a vertex; a mean over the manifold's vertices is not (CHANGELOG.md).

Degenerate regions blend, they do not switch: the pressure is ``p = d + tau`` with a depth
floor ``tau`` (:data:`PRESSURE_FLOOR_REL` times the pair's scale), and the region is ``p >= 0``.
Exactly touching faces then give their area centroid, an edge lying exactly on a face a strip
of width ``tau / |grad d|`` around it (its depth-weighted segment centroid, to ``tau``), a
vertex a region of size ``tau`` around it. The floor moves the point by ``O(tau / depth)`` of
the region's size. A region that is still empty (a pair touching within the contact tolerance
at the reference face's rim) takes the incident face's deepest vertex clamped into the face.

Stages, all pairs at once:

1. :func:`front_faces`: the three candidate faces of every row as quads of (u, w, p) in the
   reference frame, one *column* per (face, row), with the orientation sign of the projection.
2. :func:`clip_polygons`: the depth plane ``p >= 0`` cuts every quad with the same
   elementwise formulas, in the quad's cyclic order, into 8 slots (:func:`depth_polygons`).
   The four side planes (rarely reached: only a footprint crossing the reference face's rim)
   clip by Sutherland-Hodgman, on the columns that reach past them: a step starts its output
   at the entry crossing, walks the other slots (an outside one becomes the exit crossing) and
   ends with the exit crossing, so a cut turns K slots into K + 1. Repeated points are exact
   duplicates; emptied columns are dropped.
3. :func:`fan_moments`: fan triangulation from slot 0 with the closed forms for a linear
   pressure over a triangle of projected area S with vertices a, b, c::

       int p    = S (pa + pb + pc) / 3
       int x p  = S / 12 [a (2pa + pb + pc) + b (pa + 2pb + pc) + c (pa + pb + 2pc)]
       int p^2  = S / 6 (pa^2 + pb^2 + pc^2 + pa pb + pb pc + pc pa)

   A triangle with a repeated vertex contributes exactly 0, so the padding changes nothing.
4. :func:`centre_of_pressure`: the faces' moments summed per row, in face order 0, 1, 2.

Columns and order of operations follow :mod:`models.pressure_one` (the N = 1 path) term by
term, so both give the same point to the last bit.
"""
from __future__ import annotations

import numpy as np

from models.sat import sign_nonnegative

#: Depth floor of the pressure, times the pair's scale (metres): the region is ``d >= -tau``
#: and the pressure ``d + tau``. It turns exactly touching faces, edges and vertices into
#: regions of positive area (no 0/0), is far above rounding (1e-16 of the scale) and far below
#: any depth a simulator resolves, and must exceed :data:`models.sat.CONTACT_TOL_REL` so that a
#: colliding pair has a non-empty region.
PRESSURE_FLOOR_REL = 1e-9
#: Rows of a polygon array: (3, K, C) holds u, w (metres, reference frame) and the pressure p.
U, W, P = range(3)


def front_faces(frame, tau):
    """The incident box's faces that look towards the reference face, as quads.

    Parameters
    ----------
    frame : models.manifold.ReferenceFrame
        m face-axis pairs seen from their reference boxes.
    tau : ndarray, shape (m,)
        Pressure floor (metres).

    Returns
    -------
    poly : ndarray, shape (3, 4, C)
        u, w and pressure ``p = d + tau`` of each quad's vertices (metres), cyclic order.
    column_row, column_face : ndarray of int, shape (C,)
        Row (0..m-1) and incident axis (0-2) of each column, face-major; faces seen edge-on
        (``m . n == 0``) are left out.
    orientation : ndarray, shape (C,)
        +1 where the projected quad runs counter-clockwise in (u, w), else -1.
    height, half_u, half_w : ndarray, shape (m,)
        Reference half-extents along (axis, u, w) (metres).
    ref_sign : ndarray, shape (m,)
        Side (+-1) of the reference face, facing the incident box.
    """
    t_ref = frame.centre()
    ref_sign = sign_nonnegative(t_ref[0])
    m = t_ref.shape[1]
    axes, halves = frame.faces()  # (3 k, 3 role, 3 c, m), (3 k, 3 role, m)
    height, half_u, half_w = frame.half_ref()
    look = ref_sign * axes[:, 0, 0]  # (3 k, m): m_k . n
    side = -sign_nonnegative(look)
    centre = t_ref + (side * halves[:, 0])[:, None] * axes[:, 0]
    along_p = halves[:, 1][:, None] * axes[:, 1]
    along_q = halves[:, 2][:, None] * axes[:, 2]
    plus_p, minus_p = centre + along_p, centre - along_p
    vertices = np.empty((4, 3, 3, m))  # (vertex, k, coordinate, row)
    np.add(plus_p, along_q, out=vertices[0])
    np.add(minus_p, along_q, out=vertices[1])
    np.subtract(minus_p, along_q, out=vertices[2])
    np.subtract(plus_p, along_q, out=vertices[3])
    poly = np.empty((3, 4, 3, m))
    poly[U], poly[W] = vertices[:, :, 1], vertices[:, :, 2]
    poly[P] = (height - ref_sign * vertices[:, :, 0]) + tau
    poly = poly.reshape(3, 4, 3 * m)
    columns = np.arange(3 * m)
    # (m_p x m_q) . n: the projected quad's turning sense (also for a mirrored, improper pose)
    turning = axes[:, 1, 1] * axes[:, 2, 2] - axes[:, 1, 2] * axes[:, 2, 1]
    orientation = sign_nonnegative(turning).reshape(-1)
    seen = look.reshape(-1) != 0.0
    if not seen.all():
        columns = np.flatnonzero(seen)
        poly, orientation = poly[:, :, columns], orientation[columns]
    face, row = np.divmod(columns, m)
    return poly, row, face, orientation, height, half_u, half_w, ref_sign


def _cut_tables(k):
    """Lookup tables of :func:`_cut` for K slots, by inside pattern ``sum inside[i] << i``.

    The rule (the scalar path's :func:`models.pressure_one.clip`): the entry edge is the first
    edge (i, i + 1) from outside to inside, the walk is the K - 1 slots after it, the exit edge
    the first edge of the walk from inside to outside. Returns ``entry (2^K,)``, ``leave
    (2^K,)``, ``walk (K - 1, 2^K)`` slot ids and ``walk_inside (K - 1, 2^K)``.
    """
    patterns = 1 << k
    entry, leave = np.zeros(patterns, np.intp), np.zeros(patterns, np.intp)
    walk, walk_inside = np.zeros((k - 1, patterns), np.intp), np.zeros((k - 1, patterns), bool)
    for pattern in range(1, patterns - 1):
        inside = [bool(pattern >> i & 1) for i in range(k)]
        first = next(i for i in range(k) if not inside[i] and inside[(i + 1) % k])
        slots = [(first + j) % k for j in range(1, k)]
        entry[pattern] = first
        leave[pattern] = next((x for x in slots if inside[x] and not inside[(x + 1) % k]),
                              slots[0])
        walk[:, pattern] = slots
        walk_inside[:, pattern] = [inside[x] for x in slots]
    return entry, leave, walk, walk_inside


#: :func:`_cut_tables` for the slot counts a side plane meets (8 after the depth step, one
#: more per side plane that cuts).
_CUT_TABLES = {k: _cut_tables(k) for k in range(8, 12)}


def _crossings(poly, s, start, end):
    """The crossings of the plane s = 0 on the edges from slot ``start`` to slot ``end`` (C,).

    ``lam = s_a / (s_a - s_b)`` clamped to [0, 1] (0 where the two are equal), then
    ``a + lam (b - a)`` for u, w and p; shape (3, C).
    """
    c = s.shape[1]
    col = np.arange(c)
    a, b = start * c + col, end * c + col
    s_a, s_b = np.take(s, a), np.take(s, b)
    denominator = s_a - s_b
    lam = s_a / np.where(denominator != 0.0, denominator, 1.0)
    lam = np.minimum(np.maximum(np.where(denominator != 0.0, lam, 0.0), 0.0), 1.0)
    flat = poly.reshape(3, -1)
    p_a, p_b = np.take(flat, a, axis=1), np.take(flat, b, axis=1)
    return p_a + lam * (p_b - p_a)


def _cut(poly, s, pattern, coordinate, value):
    """One Sutherland-Hodgman step on columns that the plane cuts (some slots in, some out).

    Output slots: the entry crossing, the K - 1 slots after the entry edge in cyclic order (an
    outside slot replaced by the exit crossing), the exit crossing; the plane's coordinate of
    a crossing is set to its exact value. Shapes (3, K, C) -> (3, K + 1, C); ``pattern`` (C,)
    has bit i set where slot i is inside.
    """
    k, c = s.shape
    entry_of, leave_of, walk_of, walk_inside_of = _CUT_TABLES[k]
    entry, leave = np.take(entry_of, pattern), np.take(leave_of, pattern)
    enter_point = _crossings(poly, s, entry, (entry + 1) % k)
    leave_point = _crossings(poly, s, leave, (leave + 1) % k)
    enter_point[coordinate] = value
    leave_point[coordinate] = value
    walk = np.take(walk_of, pattern, axis=1) * c + np.arange(c)  # (K - 1, C) flat slots
    out = np.empty((3, k + 1, c))
    out[:, 0] = enter_point
    out[:, 1:k] = np.where(np.take(walk_inside_of, pattern, axis=1),
                           np.take(poly.reshape(3, -1), walk, axis=1), leave_point[:, None])
    out[:, k] = leave_point
    return out


def _clip_part(part, columns, s, coordinate, value, parts):
    """Clip the ``columns`` (C,) of a part by the half-plane ``s >= 0`` (K, C).

    A part is ``[poly (3, K, C'), keep (C',), live (C',) bool]``: polygons, their input
    column ids and which of them are still current. Columns the plane leaves whole stay as they
    are; cut ones (:func:`_cut`, K + 1 slots) go to a new part appended to ``parts``; cut and
    emptied ones are no longer live in ``part``. ``value`` (C,) is the plane's exact
    ``coordinate``.
    """
    poly, keep, live = part
    k = s.shape[0]
    bits = (s >= 0.0).astype(np.uint16)
    pattern = bits[0]  # bit i: slot i inside
    for i in range(1, k):
        pattern = pattern | (bits[i] << i)
    whole = pattern == (1 << k) - 1
    if whole.all():
        return
    live[columns[~whole]] = False
    rows = np.flatnonzero(~whole & (pattern != 0))
    if rows.size:
        cut = columns[rows]
        parts.append([_cut(poly[:, :, cut], s[:, rows], pattern[rows], coordinate, value[rows]),
                      keep[cut], np.ones(len(rows), bool)])


def depth_polygons(quad):
    """Clip quads (3, 4, C) to ``p >= 0``, keeping their cyclic order: (3, 8, C).

    Slot ``2 i`` is vertex i where it is inside, else the exit crossing (the first edge, in
    vertex order, from inside to outside); slot ``2 i + 1`` is the crossing on edge (i, i + 1)
    where that edge changes side, else a repeat of slot ``2 i``. Every column gets the same
    elementwise formulas (a quad entirely below the plane repeats its vertices, one entirely
    above collapses to a point of zero area), and slot 0 is always a vertex of the clipped
    polygon, the origin of :func:`fan_moments`. Crossings have ``p = 0`` exactly.
    """
    following = np.concatenate((quad[:, 1:], quad[:, :1]), axis=1)
    (u, w, p), (u_next, w_next, p_next) = quad, following
    denominator = p - p_next
    moves = denominator != 0.0
    lam = p / np.where(moves, denominator, 1.0)
    lam = np.minimum(np.maximum(np.where(moves, lam, 0.0), 0.0), 1.0)
    cross_u, cross_w = u + lam * (u_next - u), w + lam * (w_next - w)
    inside = p >= 0.0
    inside_next = np.concatenate((inside[1:], inside[:1]))
    changes = inside != inside_next
    leaves = inside & ~inside_next
    exit_u, exit_w = np.zeros(quad.shape[2]), np.zeros(quad.shape[2])
    for i in (3, 2, 1, 0):  # the first leaving edge wins
        exit_u = np.where(leaves[i], cross_u[i], exit_u)
        exit_w = np.where(leaves[i], cross_w[i], exit_w)
    out = np.empty((3, 8, quad.shape[2]))
    even, odd = out[:, 0::2], out[:, 1::2]
    np.copyto(even[U], np.where(inside, u, exit_u))
    np.copyto(even[W], np.where(inside, w, exit_w))
    np.copyto(even[P], np.where(inside, p, 0.0))
    np.copyto(odd[U], np.where(changes, cross_u, even[U]))
    np.copyto(odd[W], np.where(changes, cross_w, even[W]))
    np.copyto(odd[P], np.where(changes, 0.0, even[P]))
    return out


def clip_polygons(poly, half_u, half_w):
    """Clip quads (3, 4, C) to ``p >= 0`` (:func:`depth_polygons`) and to ``|u| <= half_u``,
    ``|w| <= half_w`` (C,).

    A side plane is applied only to the polygons whose depth clip reaches past it (largest
    u, -u, w, -w), the others being whole on its side. Columns are never copied to be
    left alone: a part keeps a mask of its current columns, applied once at the end.

    Returns
    -------
    list of (poly, keep)
        The clipped polygons in parts of equal slot count: ``poly`` (3, K, C_k) (slots past a
        polygon's end repeat a point), ``keep`` (C_k,) the input column of each.
    """
    count = poly.shape[2]
    clipped = depth_polygons(poly)
    reach = np.array([clipped[U].max(axis=0), -clipped[U].min(axis=0), clipped[W].max(axis=0),
                      -clipped[W].min(axis=0)])
    parts = [[clipped, np.arange(count), (poly[P] >= 0.0).any(axis=0)]]
    for plane, (coordinate, halves, upper) in enumerate(
            ((U, half_u, True), (U, half_u, False), (W, half_w, True), (W, half_w, False))):
        for part in list(parts):
            part_poly, keep, live = part
            bound = halves[keep]
            chosen = np.flatnonzero(live & (reach[plane][keep] > bound))
            if not chosen.size:
                continue
            bound, values = bound[chosen], part_poly[coordinate][:, chosen]
            s = bound - values if upper else bound + values
            _clip_part(part, chosen, s, coordinate, bound if upper else -bound, parts)
    done = []
    for part_poly, keep, live in parts:
        if live.all():
            done.append((part_poly, keep))
        elif live.any():
            rows = np.flatnonzero(live)
            done.append((part_poly[:, :, rows], keep[rows]))
    return done


def _rows_in_order(terms):
    """The sum of the rows of ``terms`` (R, C), added one after the other (no pairwise
    summation), as the scalar path adds them."""
    total = terms[0].copy()
    for row in terms[1:]:
        total += row
    return total


def fan_moments(poly):
    """Pressure moments of polygons (3, K, C) by a fan from slot 0.

    The K - 2 triangles are evaluated together as (K - 2, C) arrays and summed along the first
    axis, row after row (the order of the scalar path's loop).

    Returns
    -------
    ndarray, shape (4, C)
        ``int p dA``, ``int u p dA``, ``int w p dA`` and ``int p^2 dA`` over each polygon,
        signed by its orientation (counter-clockwise positive); metres^3, ^4, ^4, ^4.
    """
    a_u, a_w, a_p = poly[:, 0]
    rel_u, rel_w = poly[U, 1:] - a_u, poly[W, 1:] - a_w  # (K - 1, C)
    b_u, c_u, b_w, c_w = rel_u[:-1], rel_u[1:], rel_w[:-1], rel_w[1:]
    b_p, c_p = poly[P, 1:-1], poly[P, 2:]
    area = b_u * c_w - b_w * c_u  # twice the signed areas, (K - 2, C)
    total = (a_p + b_p) + c_p
    with_b, with_c = total + b_p, total + c_p
    sum_p = _rows_in_order(area * total)
    sum_u = _rows_in_order(area * (b_u * with_b + c_u * with_c))
    sum_w = _rows_in_order(area * (b_w * with_b + c_w * with_c))
    sum_pp = _rows_in_order(area * (a_p * total + b_p * (b_p + c_p) + c_p * c_p))
    moment_p = sum_p / 6.0
    return np.array([moment_p, a_u * moment_p + sum_u / 24.0, a_w * moment_p + sum_w / 24.0,
                     sum_pp / 12.0])


def centre_of_pressure(frame, scale, fallback):
    """The impact point and the depth of m face contacts, in the reference frame.

    Parameters
    ----------
    frame : models.manifold.ReferenceFrame
        The m pairs seen from their reference boxes.
    scale : ndarray, shape (m,)
        Pair scale (metres).
    fallback : ndarray, shape (3, m)
        The point of a row whose region is empty (coordinates (axis, u, w)); see the module
        docstring.

    Returns
    -------
    point : ndarray, shape (3, m)
        The point in the reference frame, coordinates in the cyclic order (axis, u, w).
    depth : ndarray, shape (m,)
        The deepest point of the region below the reference plane (metres, >= 0): the
        contact's penetration depth along the reference normal; -inf where the region is
        empty.
    """
    tau = PRESSURE_FLOOR_REL * scale
    poly, rows, faces, orientation, height, half_u, half_w, ref_sign = front_faces(frame, tau)
    m = len(scale)
    per_face = np.zeros((4, 3, m))
    per_face_deepest = np.full((3, m), -np.inf)
    for part, keep in clip_polygons(poly, half_u[rows], half_w[rows]):
        at = faces[keep] * m + rows[keep]
        per_face.reshape(4, -1)[:, at] = fan_moments(part) * orientation[keep]
        per_face_deepest.reshape(-1)[at] = part[P].max(axis=0)
    total = per_face[:, 0] + per_face[:, 1] + per_face[:, 2]
    weight = total[0]
    found = weight > 0.0
    safe = np.where(found, weight, 1.0)
    offset = np.maximum(0.5 * (total[3] / safe) - 0.5 * tau, 0.0)
    point = np.array([ref_sign * height - ref_sign * offset, total[1] / safe,
                      total[2] / safe])
    deepest = np.maximum(np.maximum.reduce(per_face_deepest) - tau, 0.0)
    return np.where(found, point, fallback), np.where(found, deepest, -np.inf)
