"""The impact point of a face contact: the centre of pressure of the overlap, for m pairs.

Stage 3b of the exact solver (see :mod:`models.exact`); the rule is DESIGN.md's.

The rule. The separating-axis test picks a reference face (outward normal ``n``, on the
reference box); the other box is the incident box. The contact region is the footprint, on the
reference face, of the incident box's part beyond the reference plane: every face of the
incident box that looks towards the reference face (``m . n <= 0``; one per incident axis, so
three) is projected onto the reference plane and clipped to the reference face's four side
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

Geometry. The three front faces meet at the incident box's deepest vertex, the *apex* ``V``
(pressure ``p0``, the largest). Each incident axis j gives an edge ``d_j`` from the apex (twice
the half-extent, pointing away from the reference face) along which the pressure drops by
``g_j = |n . d_j| >= 0``. Face k spans ``d_p`` and ``d_q`` (p, q = k + 1, k + 2 mod 3) and is
the parallelogram ``V, V + d_p, V + d_p + d_q, V + d_q``; its vertex pressures are
``p0, p0 - g_p, p0 - g_p - g_q, p0 - g_q`` (in that order of operations), so the inside
vertices are always the apex and its neighbours first (monotone rounding), and the depth clip
is exact bookkeeping rather than a general polygon clip.

Stages, all pairs at once:

1. :func:`apex_edges`: per row, the apex, the edges ``d_j`` and drops ``g_j``.
2. :func:`depth_slots`: per (face, row) the depth-clipped face as 4 slots after the apex, in
   the face's cyclic order, relative to the apex: ``f_p d_p``, ``f_p d_p + mu d_q``,
   ``f_q d_q + nu d_p``, ``f_q d_q``, with the fractions (:func:`_fraction`) of the edges from
   the apex (``f``) and from its neighbours (``mu``, ``nu``) that stay at ``p >= 0``, and
   pressures ``max(p, 0)`` (crossings have ``p = 0`` exactly). A triangle, quad or pentagon,
   with repeated points where it has fewer than 5; an empty region collapses onto the apex.
3. :func:`fan_sums` and :func:`moments`: fan triangulation from the apex with the closed forms
   for a linear pressure over a triangle of projected area S with vertices a, b, c::

       int p    = S (pa + pb + pc) / 3
       int x p  = S / 12 [a (2pa + pb + pc) + b (pa + 2pb + pc) + c (pa + pb + 2pc)]
       int p^2  = S / 6 (pa^2 + pb^2 + pc^2 + pa pb + pb pc + pc pa)

   with ``S = |(b - a) x (c - a)| / 2`` (the polygons are convex, so each face's fan triangles
   share its orientation). A triangle with a repeated vertex contributes exactly 0.
4. The four side planes (rarely reached: only a footprint crossing the reference face's rim)
   clip, on the faces that reach past them only, the absolute 5-point polygons by
   Sutherland-Hodgman (:func:`clip_polygons`): a step starts its output at the entry
   crossing, walks the other slots (an outside one becomes the exit crossing) and ends with the
   exit crossing, so a cut turns K slots into K + 1; those faces' moments are replaced by the
   fan of the clipped polygon from its slot 0 (:func:`fan_moments`).
5. :func:`centre_of_pressure`: the faces' moments summed per row, in face order 0, 1, 2.

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
#: The in-plane axes p = k + 1 and q = k + 2 (mod 3) of incident face k.
FACE_P, FACE_Q = [1, 2, 0], [2, 0, 1]


def apex_edges(frame, tau):
    """The incident box's deepest vertex and its three edges, in the reference frame.

    Parameters
    ----------
    frame : models.manifold.ReferenceFrame
        m face-axis pairs seen from their reference boxes.
    tau : ndarray, shape (m,)
        Pressure floor (metres).

    Returns
    -------
    apex : ndarray, shape (3, m)
        u, w (metres) and pressure ``p0 = d + tau`` (metres) of the apex.
    edge : ndarray, shape (2, 3, m)
        u, w of the edges ``d_j`` from the apex along incident axis j (metres).
    drop : ndarray, shape (3, m)
        Pressure drop ``g_j >= 0`` along edge j (metres).
    ref_sign : ndarray, shape (m,)
        Side (+-1) of the reference face, facing the incident box.
    """
    t_ref = frame.centre()
    rot = frame.rotation(0)  # (3 c, 3 j, m): incident axis j along (axis, u, w)
    height = frame.half_ref()[0]
    ref_sign = sign_nonnegative(t_ref[0])
    towards = (-sign_nonnegative(ref_sign * rot[0]) * frame.half_inc(0)) * rot  # (3 c, 3 j, m)
    apex = np.empty((3, len(ref_sign)))
    np.add((t_ref[1:] + towards[1:, 0]) + towards[1:, 1], towards[1:, 2], out=apex[:2])
    apex[P] = (height - ref_sign * (((t_ref[0] + towards[0, 0]) + towards[0, 1])
                                    + towards[0, 2])) + tau
    return apex, -2.0 * towards[1:], 2.0 * np.abs(towards[0]), ref_sign


def _fraction(level, drop):
    """Fraction (0-1) of an edge that stays at ``p >= 0``, from pressure ``level`` at its start
    and a drop ``drop >= 0`` along it: 0 if ``level < 0``, 1 if ``level >= drop``, else
    ``level / drop``. Shapes broadcast to (3, m)."""
    inside = level >= 0.0
    out = np.where(inside, 1.0, 0.0) * np.ones_like(drop)
    return np.divide(level, drop, out=out, where=inside & (level < drop))


def depth_slots(apex, edge, drop):
    """The three front faces clipped to ``p >= 0``, as 4 slots after the apex.

    Returns ``slots`` (2, 4, 3, m): u, w relative to the apex (metres) by slot, face k and row,
    and ``pressure`` (4, 3, m) (metres, >= 0); see the module docstring (stage 2).
    """
    p0 = apex[P]
    cut = _fraction(p0, drop) * edge  # (2, 3 j, m): where edge j leaves p >= 0
    level = p0 - drop  # (3 j, m): pressure at the apex's neighbour along j
    level_p, level_q, drop_p, drop_q = level[FACE_P], level[FACE_Q], drop[FACE_P], drop[FACE_Q]
    slots = np.empty((2, 4) + drop.shape)
    slots[:, 0], slots[:, 3] = cut[:, FACE_P], cut[:, FACE_Q]
    np.add(slots[:, 0], _fraction(level_p, drop_q) * edge[:, FACE_Q], out=slots[:, 1])
    np.add(slots[:, 3], _fraction(level_q, drop_p) * edge[:, FACE_P], out=slots[:, 2])
    pressure = np.empty((4,) + drop.shape)
    np.maximum(level_p, 0.0, out=pressure[0])
    np.maximum(level_p - drop_q, 0.0, out=pressure[1])
    pressure[2] = pressure[1]
    np.maximum(level_q, 0.0, out=pressure[3])
    return slots, pressure


def _rows_in_order(terms):
    """The sum of the rows of ``terms`` (R, ...), added one after the other (no pairwise
    summation), as the scalar path adds them."""
    total = terms[0].copy()
    for row in terms[1:]:
        total += row
    return total


def fan_sums(rel_u, rel_w, pressure, apex_p):
    """Fan sums of polygons from their apex: ``rel_u``, ``rel_w`` (K - 1, ...) the other
    slots relative to the apex (metres), ``pressure`` (K - 1, ...) theirs, ``apex_p`` the
    apex's. The K - 2 triangles are evaluated together and summed row after row (the order of
    the scalar path's loop).

    Returns ``[sum_p, sum_u, sum_w, sum_pp]``, each (...): 6, 24, 24 and 12 times
    ``int p dA``, ``int (u - u_apex) p dA``, ``int (w - w_apex) p dA``, ``int p^2 dA``.
    """
    b_u, c_u, b_w, c_w = rel_u[:-1], rel_u[1:], rel_w[:-1], rel_w[1:]
    b_p, c_p = pressure[:-1], pressure[1:]
    area = np.abs(b_u * c_w - b_w * c_u)  # twice the areas, (K - 2, ...)
    total = (apex_p + b_p) + c_p
    with_b, with_c = total + b_p, total + c_p
    return [_rows_in_order(area * total),
            _rows_in_order(area * (b_u * with_b + c_u * with_c)),
            _rows_in_order(area * (b_w * with_b + c_w * with_c)),
            _rows_in_order(area * (apex_p * total + b_p * (b_p + c_p) + c_p * c_p))]


def moments(sums, apex_u, apex_w):
    """``int p dA``, ``int u p dA``, ``int w p dA``, ``int p^2 dA`` (4, ...) (metres^3, ^4, ^4,
    ^4) from :func:`fan_sums` and the apex's u, w."""
    sum_p, sum_u, sum_w, sum_pp = sums
    moment_p = sum_p / 6.0
    return np.array([moment_p, apex_u * moment_p + sum_u / 24.0,
                     apex_w * moment_p + sum_w / 24.0, sum_pp / 12.0])


def fan_moments(poly):
    """:func:`moments` (4, C) of polygons (3, K, C) (absolute u, w, p), fan from slot 0."""
    a_u, a_w, a_p = poly[:, 0]
    return moments(fan_sums(poly[U, 1:] - a_u, poly[W, 1:] - a_w, poly[P, 1:], a_p), a_u, a_w)


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


#: Slots of a depth-clipped face with its apex (:func:`depth_slots`).
FACE_SLOTS = 5
#: :func:`_cut_tables` for the slot counts a side plane meets (5 after the depth clip, one
#: more per side plane that cuts).
_CUT_TABLES = {k: _cut_tables(k) for k in range(FACE_SLOTS, FACE_SLOTS + 4)}


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


def clip_polygons(poly, half_u, half_w):
    """Clip polygons (3, K, C) (absolute u, w, p) to ``|u| <= half_u``, ``|w| <= half_w``
    (C,).

    A side plane is applied only to the polygons that reach past it (largest u, -u, w, -w of
    the input), the others being whole on its side. Columns are never copied to be left alone:
    a part keeps a mask of its current columns, applied once at the end.

    Returns
    -------
    list of (poly, keep)
        The clipped polygons in parts of equal slot count: ``poly`` (3, K', C_k) (slots past a
        polygon's end repeat a point), ``keep`` (C_k,) the input column of each.
    """
    count = poly.shape[2]
    reach = np.array([poly[U].max(axis=0), -poly[U].min(axis=0), poly[W].max(axis=0),
                      -poly[W].min(axis=0)])
    parts = [[poly, np.arange(count), np.ones(count, bool)]]
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


def _side_clipped(apex, slots, pressure, half_u, half_w, per_face, deepest):
    """Stage 4: replace, in ``per_face`` (4, 3 m) and ``deepest`` (3 m,), the moments and the
    largest pressure of the faces that reach past a side plane (and whose apex has
    ``p0 > 0``) by those of their clipped polygons (0 and -inf where nothing is left)."""
    m = apex.shape[1]
    apex_uw, bound = apex[:2, None], np.array([half_u, half_w])[:, None]
    reach = ((apex_uw + np.maximum.reduce(slots, axis=1, initial=0.0) > bound)
             | (apex_uw + np.minimum.reduce(slots, axis=1, initial=0.0) < -bound))
    columns = np.flatnonzero((reach[0] | reach[1]) & (apex[P] > 0.0))
    if not columns.size:
        return
    rows = columns % m
    poly = np.empty((3, FACE_SLOTS, len(columns)))
    poly[:, 0] = apex[:, rows]
    np.add(apex[:2, None, rows], slots.reshape(2, 4, -1)[:, :, columns], out=poly[:2, 1:])
    poly[P, 1:] = pressure.reshape(4, -1)[:, columns]
    per_face[:, columns], deepest[columns] = 0.0, -np.inf
    for part, keep in clip_polygons(poly, half_u[rows], half_w[rows]):
        per_face[:, columns[keep]] = fan_moments(part)
        deepest[columns[keep]] = part[P].max(axis=0)


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
    m = len(scale)
    apex, edge, drop, ref_sign = apex_edges(frame, tau)
    height, half_u, half_w = frame.half_ref()
    slots, pressure = depth_slots(apex, edge, drop)
    per_face = moments(fan_sums(slots[U], slots[W], pressure, apex[P]), apex[U], apex[W])
    per_face = per_face.reshape(4, 3 * m)
    deepest = np.empty((3, m))
    deepest[:] = apex[P]
    deepest = deepest.reshape(-1)
    _side_clipped(apex, slots, pressure, half_u, half_w, per_face, deepest)
    per_face = per_face.reshape(4, 3, m)
    total = per_face[:, 0] + per_face[:, 1] + per_face[:, 2]
    weight = total[0]
    found = weight > 0.0
    safe = np.where(found, weight, 1.0)
    offset = np.maximum(0.5 * (total[3] / safe) - 0.5 * tau, 0.0)
    point = np.array([ref_sign * height - ref_sign * offset, total[1] / safe,
                      total[2] / safe])
    region_depth = np.maximum(np.maximum.reduce(deepest.reshape(3, m)) - tau, 0.0)
    return np.where(found, point, fallback), np.where(found, region_depth, -np.inf)
