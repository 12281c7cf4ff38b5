"""The impact point of a face contact: the centre of pressure of the overlap, for m pairs.

Stage 3b of the exact solver (see :mod:`impactnet.models.box.exact`); the rule is DESIGN.md's.

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

Columns and order of operations follow :mod:`impactnet.models.box.pressure_one` (the N = 1 path)
term by
term, so both give the same point to the last bit.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box.sat import sign_nonnegative

#: Depth floor of the pressure, times the pair's scale (metres): the region is ``d >= -tau``
#: and the pressure ``d + tau``. It turns exactly touching faces, edges and vertices into
#: regions of positive area (no 0/0), is far above rounding (1e-16 of the scale) and far below
#: any depth a simulator resolves, and must exceed :data:`impactnet.models.box.sat.CONTACT_TOL_REL`
#: so that a
#: colliding pair has a non-empty region.
PRESSURE_FLOOR_REL = 1e-9
#: A face contact's depth is the SAT overlap along its normal unless the region's deepest point
#: is shallower than that by more than this (x pair scale, metres): the incident box's deepest
#: vertex then hangs beyond the reference face, and the region's depth is the penetration.
#: Above the rounding of ``(d + tau) - tau`` (1e-16 of the scale), so that where the two agree
#: the depth stays the SAT overlap to the last bit (the region labeller's).
REGION_DEPTH_TOL_REL = 1e-9
#: Rows of a polygon array: (3, K, C) holds u, w (metres, reference frame) and the pressure p.
U, W, P = range(3)
#: The in-plane axes p = k + 1 and q = k + 2 (mod 3) of incident face k.
FACE_P, FACE_Q = [1, 2, 0], [2, 0, 1]


def apex_edges(frame, height, tau):
    """The incident box's deepest vertex and its three edges, in the reference frame.

    Parameters
    ----------
    frame : impactnet.models.box.manifold.ReferenceFrame
        m face-axis pairs seen from their reference boxes.
    height : ndarray, shape (m,)
        Reference half-extent along the reference axis (metres).
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
    out = np.broadcast_to(inside, drop.shape).astype(np.float64)
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

    The rule (the scalar path's :func:`impactnet.models.box.pressure_one.clip`): the entry edge is
    the first
    edge (i, i + 1) from outside to inside, the walk is the K - 1 slots after it, the exit edge
    the first edge of the walk from inside to outside. Returns ``ends (2 start/end, 2
    entry/exit, 2^K)``, ``walk (K - 1, 2^K)`` slot ids and ``walk_inside (K - 1, 2^K)``.
    """
    patterns = 1 << k
    ends = np.zeros((2, 2, patterns), np.intp)
    walk, walk_inside = np.zeros((k - 1, patterns), np.intp), np.zeros((k - 1, patterns), bool)
    for pattern in range(1, patterns - 1):
        inside = [bool(pattern >> i & 1) for i in range(k)]
        first = next(i for i in range(k) if not inside[i] and inside[(i + 1) % k])
        slots = [(first + j) % k for j in range(1, k)]
        leave = next(x for x in slots if inside[x] and not inside[(x + 1) % k])
        ends[:, :, pattern] = [[first, leave], [(first + 1) % k, (leave + 1) % k]]
        walk[:, pattern] = slots
        walk_inside[:, pattern] = [inside[x] for x in slots]
    return ends, walk, walk_inside


#: Slots of a depth-clipped face with its apex (:func:`depth_slots`).
FACE_SLOTS = 5
#: The side planes in the order they clip: (coordinate, bound index (0 half_u, 1 half_w),
#: upper side).
_SIDE_PLANES = ((U, 0, True), (U, 0, False), (W, 1, True), (W, 1, False))
#: :func:`_cut_tables` for the slot counts a side plane meets (5 after the depth clip, one
#: more per side plane that cuts; at most 8, the patterns fit a byte).
_CUT_TABLES = {k: _cut_tables(k) for k in range(FACE_SLOTS, FACE_SLOTS + len(_SIDE_PLANES))}


def _cut(poly, s, pattern, coordinate, value):
    """One Sutherland-Hodgman step on columns that the plane cuts (some slots in, some out).

    Output slots: the entry crossing, the K - 1 slots after the entry edge in cyclic order (an
    outside slot replaced by the exit crossing), the exit crossing. A crossing on the edge
    from slot a to slot b is ``a + lam (b - a)`` (u, w and p), ``lam = s_a / (s_a - s_b)``
    (in [0, 1]: the two are on different sides), with the plane's coordinate set to its exact
    ``value`` (C,). Shapes (3, K, C) -> (3, K + 1, C); ``pattern`` (C,) has bit i set where
    slot i is inside.
    """
    k, c = s.shape
    ends_of, walk_of, walk_inside_of = _CUT_TABLES[k]
    column = np.arange(c)
    ends = np.take(ends_of, pattern, axis=2) * c + column  # (2 start/end, 2, C) flat slots
    s_a, s_b = np.take(s, ends)
    lam = s_a / (s_a - s_b)
    flat = poly.reshape(3, -1)
    start, end = np.take(flat, ends[0], axis=1), np.take(flat, ends[1], axis=1)
    crossing = start + lam * (end - start)  # (3, 2 entry/exit, C)
    crossing[coordinate] = value
    walk = np.take(walk_of, pattern, axis=1) * c + column  # (K - 1, C) flat slots
    out = np.empty((3, k + 1, c))
    out[:, 0], out[:, k] = crossing[:, 0], crossing[:, 1]
    out[:, 1:k] = np.where(np.take(walk_inside_of, pattern, axis=1),
                           np.take(flat, walk, axis=1), crossing[:, 1, None])
    return out


def clip_polygons(poly, half_u, half_w):
    """Clip polygons (3, K, C) (absolute u, w, p) to ``|u| <= half_u``, ``|w| <= half_w``
    (C,), by Sutherland-Hodgman (:func:`_cut`), plane by plane (:data:`_SIDE_PLANES`).

    All polygons stay in one array: a plane that cuts some of them adds a slot to every
    column, a repeat of the last slot where the plane does not cut (a repeated point changes
    neither a later cut nor the fan's sums).

    Returns
    -------
    poly : ndarray, shape (3, K', C)
        The clipped polygons (K <= K' <= K + 4).
    live : ndarray of bool, shape (C,)
        False where nothing is left.
    """
    k, count = poly.shape[1:]
    halves = (half_u, half_w)
    live = np.ones(count, bool)
    grown = np.empty((3, k + len(_SIDE_PLANES), count))
    grown[:, :k] = poly
    for coordinate, which, upper in _SIDE_PLANES:
        bound = halves[which]
        s = bound - grown[coordinate, :k] if upper else bound + grown[coordinate, :k]
        pattern = np.packbits(s >= 0.0, axis=0, bitorder="little")[0]  # bit i: slot i inside
        live &= pattern != 0
        cut = np.flatnonzero(live & (pattern != (1 << k) - 1))
        if cut.size:
            clipped = _cut(np.take(grown[:, :k], cut, axis=2), np.take(s, cut, axis=1),
                           pattern[cut], coordinate, bound[cut] if upper else -bound[cut])
            grown[:, k] = grown[:, k - 1]
            grown[:, :k + 1, cut] = clipped
            k += 1
    return grown[:, :k], live


def _side_clipped(apex, slots, pressure, half_u, half_w, per_face, deepest):
    """Stage 4: replace, in ``per_face`` (4, 3 m) and ``deepest`` (3 m,), the moments and the
    largest pressure of the faces that reach past a side plane (of rows with ``p0 > 0``) by
    those of their clipped polygons (0 and -inf where nothing is left).

    Only rows near the rim are searched: no slot of a row reaches further from its apex, in u
    or w, than the sum of the faces' first slots' (the fractions of the apex's edges), and
    that bound holds for the rounded values too (rounding is monotone).
    """
    m = apex.shape[1]
    bound = np.array([half_u, half_w])
    extent = np.abs(slots[:, 0])  # (2, 3 k, m)
    extent = (extent[:, 0] + extent[:, 1]) + extent[:, 2]
    near = np.flatnonzero(((apex[:2] + extent > bound) | (apex[:2] - extent < -bound)).any(axis=0)
                          & (apex[P] > 0.0))
    if not near.size:
        return
    near_slots, apex_uw = np.take(slots, near, axis=3), apex[:2, None, near]
    reach = ((apex_uw + np.maximum.reduce(near_slots, axis=1, initial=0.0) > bound[:, None, near])
             | (apex_uw + np.minimum.reduce(near_slots, axis=1, initial=0.0)
                < -bound[:, None, near]))
    face, at = np.nonzero(reach[0] | reach[1])
    if not face.size:
        return
    rows = near[at]
    columns = face * m + rows
    poly = np.empty((3, FACE_SLOTS, len(columns)))
    poly[:, 0] = apex[:, rows]
    np.add(apex[:2, None, rows], near_slots[:, :, face, at], out=poly[:2, 1:])
    poly[P, 1:] = pressure[:, face, rows]
    poly, live = clip_polygons(poly, half_u[rows], half_w[rows])
    per_face[:, columns] = np.where(live, fan_moments(poly), 0.0)
    deepest[columns] = np.where(live, poly[P].max(axis=0), -np.inf)


def centre_of_pressure(frame, scale, fallback):
    """The impact point and the depth of m face contacts, in the reference frame.

    Parameters
    ----------
    frame : impactnet.models.box.manifold.ReferenceFrame
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
    pressure : ndarray, shape (m,)
        The integral of the pressure over the region, ``int (d + tau) dA`` (m^3; ``tau`` the
        depth floor): the weight of the contact in a body-level summary; 0 where the region
        is empty.
    """
    tau = PRESSURE_FLOOR_REL * scale
    m = len(scale)
    height, half_u, half_w = frame.half_ref()
    apex, edge, drop, ref_sign = apex_edges(frame, height, tau)
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
    return (np.where(found, point, fallback), np.where(found, region_depth, -np.inf),
            np.where(found, weight, 0.0))
