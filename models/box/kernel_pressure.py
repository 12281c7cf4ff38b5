"""Stage 4 of the exact box-box solver: the impact point of a face contact, one pair.

The rule (docs/design.md). The separating-axis test picks a reference face (outward normal ``n``, on
the reference box); the other box is the incident box. The contact region is the footprint, on
the reference face, of the incident box's part beyond the reference plane: every face of the
incident box that looks towards the reference face (``m . n <= 0``; one per incident axis, so
three) is projected onto the reference plane and clipped to the reference face's four side
planes and to ``depth >= 0``. The depth ``d`` is measured along ``n`` from the reference plane;
it is linear over each projected face. Under a pressure proportional to the depth, the point is
the pressure-weighted mean of the mid-surface points ``y - n d(y) / 2``:

* tangential part: ``int y d dA / int d dA`` over the footprint (projected areas);
* offset below the plane: ``int d^2 dA / (2 int d dA)``.

Where the incident box crosses the reference plane over its whole footprint (the usual case)
the tangential part is the tangential centroid of the overlap volume inside the reference
face's prism. Because every front face takes part, the point is continuous where the incident
face changes (a corner landing first, an edge-down box through its 45-degree tie) and where the
polygon gains or loses a vertex; a mean over the manifold's vertices is not (CHANGELOG.md).

Degenerate regions blend, they do not switch: the pressure is ``p = d + tau`` with a depth floor
``tau`` (``PRESSURE_FLOOR_REL`` times the pair's scale), and the region is ``p >= 0``. Exactly
touching faces then give their area centroid, an edge lying exactly on a face a strip of width
``tau / |grad d|`` around it (its depth-weighted segment centroid, to ``tau``), a vertex a region
of size ``tau`` around it. The floor moves the point by ``O(tau / depth)`` of the region's size.
A region that is still empty (a pair touching within the contact tolerance at the reference
face's rim) takes the incident face's deepest vertex clamped into the face.

Geometry. The three front faces meet at the incident box's deepest vertex, the *apex* ``V``
(pressure ``p0``, the largest). Each incident axis j gives an edge ``d_j`` from the apex (twice
the half-extent, pointing away from the reference face) along which the pressure drops by
``g_j = |n . d_j| >= 0``. Face k spans ``d_p`` and ``d_q`` (p, q = k + 1, k + 2 mod 3) and is the
parallelogram ``V, V + d_p, V + d_p + d_q, V + d_q``; its vertex pressures are ``p0, p0 - g_p,
p0 - g_p - g_q, p0 - g_q`` (in that order of operations), so the inside vertices are always the
apex and its neighbours first (monotone rounding), and the depth clip is exact bookkeeping
rather than a general polygon clip.

Stages:

1. :func:`apex_edges`: the apex, the edges ``d_j`` and drops ``g_j``.
2. :func:`depth_slots`: per face the depth-clipped face as 4 slots after the apex, in the face's
   cyclic order, relative to the apex: ``f_p d_p``, ``f_p d_p + mu d_q``, ``f_q d_q + nu d_p``,
   ``f_q d_q``, with the fractions (:func:`fraction`) of the edges from the apex (``f``) and from
   its neighbours (``mu``, ``nu``) that stay at ``p >= 0``, and pressures ``max(p, 0)``
   (crossings have ``p = 0`` exactly). A triangle, quad or pentagon, with repeated points where
   it has fewer than 5; an empty region collapses onto the apex.
3. :func:`triangle` and :func:`moments`: fan triangulation from the apex with the closed forms
   for a linear pressure over a triangle of projected area S with vertices a, b, c::

       int p    = S (pa + pb + pc) / 3
       int x p  = S / 12 [a (2pa + pb + pc) + b (pa + 2pb + pc) + c (pa + pb + 2pc)]
       int p^2  = S / 6 (pa^2 + pb^2 + pc^2 + pa pb + pb pc + pc pa)

   with ``S = |(b - a) x (c - a)| / 2`` (the polygons are convex, so each face's fan triangles
   share its orientation). A triangle with a repeated vertex contributes exactly 0. The sums
   start at the first triangle and add the others in fan order.
4. The four side planes (rarely reached: only a footprint crossing the reference face's rim)
   clip, on the faces that reach past them only, the absolute 5-point polygon by
   Sutherland-Hodgman (:func:`cut`): a step starts its output at the entry crossing, walks the
   other slots (an outside one becomes the exit crossing) and ends with the exit crossing, so a
   cut turns K slots into K + 1; that face's moments are replaced by the fan of the clipped
   polygon from its slot 0 (:func:`fan_moments`).
5. :func:`centre_of_pressure`: the faces' moments summed, in face order 0, 1, 2.
"""
from __future__ import annotations

import math

from impactnet.models.box.kernel_face import FACE_SCRATCH, cyclic, reference_axes
from impactnet.models.box.kernel_frame import maximum, minimum, sign
from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL
from impactnet.models.compiled import jit

#: Slots of a depth-clipped face with its apex, and at most one more per side plane.
FACE_SLOTS, MAX_SLOTS = 5, 9
#: Scratch slots (float64) of the two polygon buffers of the side clip: u, w, p per slot.
POLYGON, SPARE = FACE_SCRATCH, FACE_SCRATCH + 3 * MAX_SLOTS
#: Scratch slots the stages up to this one use (from 0).
PRESSURE_SCRATCH = FACE_SCRATCH + 6 * MAX_SLOTS


@jit
def apex_edges(h_inc, rot_ri, t_ri, ref_axis, height, tau):
    """The incident box's deepest vertex and its three edges, in the reference frame.

    Returns
    -------
    apex : 3-tuple
        u, w (metres) and pressure ``p0 = d + tau`` (metres) of the apex.
    edge_u, edge_w : 3-tuple
        u, w of the edges ``d_j`` from the apex along incident axis j (metres).
    drop : 3-tuple
        Pressure drop ``g_j >= 0`` along edge j (metres).
    ref_sign : float
        Side (+-1) of the reference face, facing the incident box.
    """
    tr = cyclic(t_ri, ref_axis)
    rot = reference_axes(rot_ri, ref_axis, 0)  # incident axis j along (axis, u, w)
    ref_sign = sign(tr[0])
    reach = ((-sign(ref_sign * rot[0])) * h_inc[0], (-sign(ref_sign * rot[1])) * h_inc[1],
             (-sign(ref_sign * rot[2])) * h_inc[2])  # towards the reference face
    along = ((tr[0] + reach[0] * rot[0]) + reach[1] * rot[1]) + reach[2] * rot[2]
    apex = (((tr[1] + reach[0] * rot[3]) + reach[1] * rot[4]) + reach[2] * rot[5],
            ((tr[2] + reach[0] * rot[6]) + reach[1] * rot[7]) + reach[2] * rot[8],
            (height - ref_sign * along) + tau)
    edge_u = (-2.0 * (reach[0] * rot[3]), -2.0 * (reach[1] * rot[4]), -2.0 * (reach[2] * rot[5]))
    edge_w = (-2.0 * (reach[0] * rot[6]), -2.0 * (reach[1] * rot[7]), -2.0 * (reach[2] * rot[8]))
    drop = (2.0 * abs(reach[0] * rot[0]), 2.0 * abs(reach[1] * rot[1]),
            2.0 * abs(reach[2] * rot[2]))
    return apex, edge_u, edge_w, drop, ref_sign


@jit
def fraction(level, drop):
    """Fraction (0-1) of an edge that stays at ``p >= 0``, from pressure ``level`` at its start
    and a drop ``drop >= 0`` along it: 0 if ``level < 0``, 1 if ``level >= drop``, else
    ``level / drop``."""
    if not level >= 0.0:
        return 0.0
    return level / drop if level < drop else 1.0


@jit
def depth_slots(p0, edge_u, edge_w, drop, k):
    """Face k clipped to ``p >= 0`` as 4 slots after the apex (module docstring, stage 2):
    ``(u, w, p)`` 3-tuples, u and w relative to the apex (metres), p >= 0 (metres)."""
    p, q = (k + 1) % 3, (k + 2) % 3
    first = fraction(p0, drop[p])
    last = fraction(p0, drop[q])
    level_p, level_q = p0 - drop[p], p0 - drop[q]
    s0 = (first * edge_u[p], first * edge_w[p], maximum(level_p, 0.0))
    s3 = (last * edge_u[q], last * edge_w[q], maximum(level_q, 0.0))
    mu, nu = fraction(level_p, drop[q]), fraction(level_q, drop[p])
    far = maximum(level_p - drop[q], 0.0)
    s1 = (s0[0] + mu * edge_u[q], s0[1] + mu * edge_w[q], far)
    s2 = (s3[0] + nu * edge_u[p], s3[1] + nu * edge_w[p], far)
    return s0, s1, s2, s3


@jit
def triangle(b, c, apex_p):
    """The fan sums' terms of the triangle (apex, b, c), b and c ``(u, w, p)`` relative to the
    apex: 6, 24, 24 and 12 times ``int p dA``, ``int (u - u_apex) p dA``,
    ``int (w - w_apex) p dA``, ``int p^2 dA``."""
    area = abs(b[0] * c[1] - b[1] * c[0])  # twice the area
    total = (apex_p + b[2]) + c[2]
    with_b, with_c = total + b[2], total + c[2]
    return (area * total, area * (b[0] * with_b + c[0] * with_c),
            area * (b[1] * with_b + c[1] * with_c),
            area * (apex_p * total + b[2] * (b[2] + c[2]) + c[2] * c[2]))


@jit
def added(sums, terms):
    """Four running sums plus four terms."""
    return (sums[0] + terms[0], sums[1] + terms[1], sums[2] + terms[2], sums[3] + terms[3])


@jit
def moments(sums, apex_u, apex_w):
    """``int p dA``, ``int u p dA``, ``int w p dA``, ``int p^2 dA`` (metres^3, ^4, ^4, ^4) from
    the fan sums of :func:`triangle` and the apex's u, w."""
    moment_p = sums[0] / 6.0
    return (moment_p, apex_u * moment_p + sums[1] / 24.0, apex_w * moment_p + sums[2] / 24.0,
            sums[3] / 12.0)


@jit
def _side(work, at, slot, coordinate, bound, upper):
    """Signed distance (metres) of polygon slot ``slot`` inside a side plane: ``bound - x``
    for an upper bound, ``bound + x`` for a lower one (x = u or w)."""
    x = work[at + 3 * slot + coordinate]
    return bound - x if upper else bound + x


@jit
def _crossing(work, at, a, b, coordinate, bound, upper, out):
    """The plane's crossing on the polygon edge from slot a to slot b (on different sides),
    ``a + lam (b - a)`` in u, w and p with ``lam = s_a / (s_a - s_b)``, its plane coordinate
    set to the exact bound; written at scratch slot ``out``."""
    s_a = _side(work, at, a, coordinate, bound, upper)
    s_b = _side(work, at, b, coordinate, bound, upper)
    lam = s_a / (s_a - s_b)
    for x in range(3):
        start = work[at + 3 * a + x]
        work[out + x] = start + lam * (work[at + 3 * b + x] - start)
    work[out + coordinate] = bound if upper else -bound


@jit
def cut(work, at, to, k, coordinate, bound, upper):
    """One Sutherland-Hodgman step of the K-slot polygon at scratch ``at`` by a side plane,
    into scratch ``to``; returns the slots written: 0 where no slot is inside, K + 1 after a
    cut, -1 where every slot is inside (nothing written).

    The entry edge is the first edge (i, i + 1) from outside to inside, the walk is the K - 1
    slots after it, the exit edge the first edge of the walk from inside to outside. Output:
    the entry crossing, the walk (an outside slot replaced by the exit crossing), the exit
    crossing.
    """
    inside = 0
    for m in range(k):
        if _side(work, at, m, coordinate, bound, upper) >= 0.0:
            inside |= 1 << m
    if inside == 0:
        return 0
    if inside == (1 << k) - 1:
        return -1
    first = 0
    while (inside >> first & 1) or not (inside >> ((first + 1) % k) & 1):
        first += 1
    leave = (first + 1) % k
    while not (inside >> leave & 1) or (inside >> ((leave + 1) % k) & 1):
        leave = (leave + 1) % k
    _crossing(work, at, first, (first + 1) % k, coordinate, bound, upper, to)
    _crossing(work, at, leave, (leave + 1) % k, coordinate, bound, upper, to + 3 * k)
    for jj in range(1, k):
        x = (first + jj) % k
        source = at + 3 * x if inside >> x & 1 else to + 3 * k
        for c in range(3):
            work[to + 3 * jj + c] = work[source + c]
    return k + 1


@jit
def fan_moments(work, at, k):
    """:func:`moments` of the K-slot polygon at scratch ``at`` (absolute u, w, p), fan from
    slot 0, and its largest pressure (metres)."""
    a_u, a_w, a_p = work[at], work[at + 1], work[at + 2]
    deepest = a_p
    b = (work[at + 3] - a_u, work[at + 4] - a_w, work[at + 5])
    deepest = maximum(deepest, b[2])
    sums = (0.0, 0.0, 0.0, 0.0)
    for m in range(2, k):
        c = (work[at + 3 * m] - a_u, work[at + 3 * m + 1] - a_w, work[at + 3 * m + 2])
        deepest = maximum(deepest, c[2])
        terms = triangle(b, c, a_p)
        sums = terms if m == 2 else added(sums, terms)
        b = c
    return moments(sums, a_u, a_w), deepest


@jit
def clipped_face(work, apex, slots, half_u, half_w):
    """Stage 4 for one face that reaches past a side plane: its polygon (the apex and its 4
    slots) clipped to ``|u| <= half_u``, ``|w| <= half_w``, plane by plane (u upper, u lower,
    w upper, w lower). Returns its moments and largest pressure, or zeros and -inf where
    nothing is left."""
    at, spare, k = POLYGON, SPARE, FACE_SLOTS
    work[at], work[at + 1], work[at + 2] = apex[0], apex[1], apex[2]
    for m in range(4):
        s = slots[m]
        work[at + 3 + 3 * m] = apex[0] + s[0]
        work[at + 4 + 3 * m] = apex[1] + s[1]
        work[at + 5 + 3 * m] = s[2]
    for plane in range(4):
        coordinate, upper = plane // 2, plane % 2 == 0
        written = cut(work, at, spare, k, coordinate, half_u if coordinate == 0 else half_w,
                      upper)
        if written == 0:
            return (0.0, 0.0, 0.0, 0.0), -math.inf
        if written > 0:
            at, spare, k = spare, at, written
    return fan_moments(work, at, k)


@jit
def _reaches(apex, slots, half_u, half_w):
    """Whether some slot of a face (relative to the apex) lies past a side plane."""
    for c, bound in ((0, half_u), (1, half_w)):
        high, low = 0.0, 0.0
        for m in range(4):
            high, low = maximum(high, slots[m][c]), minimum(low, slots[m][c])
        if apex[c] + high > bound or apex[c] + low < -bound:
            return True
    return False


@jit
def centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale, fallback, work):
    """The impact point and the depth of a face contact, in the reference frame (stages 1-5).

    Parameters
    ----------
    h_ref, h_inc, rot_ri, t_ri : tuples
        :func:`impactnet.models.box.kernel_face.reference_view`'s.
    ref_axis : int
        The reference face's axis (0-2).
    scale : float
        Pair scale (metres).
    fallback : 3-tuple
        The point where the region is empty, coordinates (axis, u, w) (metres).
    work : ndarray
        Scratch, at least :data:`PRESSURE_SCRATCH` float64.

    Returns
    -------
    point : 3-tuple
        The point in the reference frame, coordinates (axis, u, w) (metres).
    depth : float
        The deepest point of the region below the reference plane (metres, >= 0): the
        contact's penetration depth along the reference normal; -inf where the region is empty.
    pressure : float
        ``int (d + tau) dA`` over the region (m^3): the weight of the contact in a body-level
        summary; 0 where the region is empty.
    """
    tau = PRESSURE_FLOOR_REL * scale
    height, half_u, half_w = cyclic(h_ref, ref_axis)
    apex, edge_u, edge_w, drop, ref_sign = apex_edges(h_inc, rot_ri, t_ri, ref_axis, height, tau)
    p0 = apex[2]
    if not p0 > 0.0:  # no point of the incident box reaches p >= 0: every sum is <= 0
        return fallback, -math.inf, 0.0
    # Only footprints near the rim are clipped: no slot reaches further from the apex, in u or
    # w, than the faces' first slots together (rounding is monotone).
    extent_u, extent_w = 0.0, 0.0
    for j in (1, 2, 0):  # the edges that faces 0, 1, 2 start on
        first = fraction(p0, drop[j])
        extent_u, extent_w = extent_u + abs(first * edge_u[j]), extent_w + abs(first * edge_w[j])
    near = (apex[0] + extent_u > half_u or apex[0] - extent_u < -half_u
            or apex[1] + extent_w > half_w or apex[1] - extent_w < -half_w)
    total = (0.0, 0.0, 0.0, 0.0)
    deepest = -math.inf
    for k in range(3):
        slots = depth_slots(p0, edge_u, edge_w, drop, k)
        sums = added(added(triangle(slots[0], slots[1], p0), triangle(slots[1], slots[2], p0)),
                     triangle(slots[2], slots[3], p0))
        face, largest = moments(sums, apex[0], apex[1]), p0
        if near and _reaches(apex, slots, half_u, half_w):
            face, largest = clipped_face(work, apex, slots, half_u, half_w)
        total = face if k == 0 else added(total, face)
        deepest = largest if k == 0 else maximum(deepest, largest)
    weight = total[0]
    if not weight > 0.0:
        return fallback, -math.inf, 0.0
    offset = maximum(0.5 * (total[3] / weight) - 0.5 * tau, 0.0)
    point = (ref_sign * height - ref_sign * offset, total[1] / weight, total[2] / weight)
    return point, maximum(deepest - tau, 0.0), weight
