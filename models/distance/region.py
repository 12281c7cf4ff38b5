"""The closest region of two separated convex polytopes and its centroid (compiled row
functions, :mod:`impactnet.models.compiled`).

Given the closest direction ``n`` (unit, from A towards B) and a slack ``tol`` (m), A's support
set is its vertices within ``tol`` of its extreme along ``n``, B's those within ``tol`` of its
extreme along ``-n``. Both are projected onto the plane perpendicular to ``n`` (coordinates
``(e1, e2)`` about an origin near the region), hulled in 2D (a point, a segment or a convex
polygon, counter-clockwise; Andrew's monotone chain, points within ``tol`` of a hull edge's
line dropped) and intersected (a point; two segments: their crossing, or the overlap of two
parallel ones; a segment clipped by a polygon; a polygon clipped by a polygon, its edges pushed
out by ``tol`` so that regions meeting along an edge still meet). The intersection's centroid
is the closest region's centroid in the plane: a polygon's area centroid (a polygon thinner
than :data:`~.tolerances.THIN_AREA_FACTOR` ``tol`` answers with the midpoint of its longest
chord), a segment's midpoint, a point.

Scratch: 2D coordinates in ``work`` (float64) from offset ``base``: the support sets, their
hulls and two clip buffers, ``cap`` = the most vertices of a hull (:func:`region_slots`).
"""
from __future__ import annotations

import math

from impactnet.models.compiled import jit
from impactnet.models.distance.tolerances import THIN_AREA_FACTOR


@jit
def region_slots(cap):
    """Scratch entries of the region stage for hulls of up to ``cap`` vertices."""
    return 20 * cap + 16


@jit
def plane_basis(nx, ny, nz):
    """Two unit vectors (e1, e2), each 3 floats, completing the unit ``n`` to a right-handed
    frame (e1 perpendicular to n's smallest component's axis)."""
    if abs(nx) <= abs(ny) and abs(nx) <= abs(nz):
        ux, uy, uz = 0.0, nz, -ny
    elif abs(ny) <= abs(nz):
        ux, uy, uz = -nz, 0.0, nx
    else:
        ux, uy, uz = ny, -nx, 0.0
    norm = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / norm, uy / norm, uz / norm
    return ux, uy, uz, ny * uz - nz * uy, nz * ux - nx * uz, nx * uy - ny * ux


@jit
def _cross(ox, oy, ax, ay, bx, by):
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


@jit
def _sort(px, py, k):
    """Sort the first ``k`` points by x, then y (insertion sort: k is a face's corners)."""
    for i in range(1, k):
        x, y, j = px[i], py[i], i - 1
        while j >= 0 and (px[j] > x or (px[j] == x and py[j] > y)):
            px[j + 1], py[j + 1] = px[j], py[j]
            j -= 1
        px[j + 1], py[j + 1] = x, y


@jit
def hull2d(px, py, k, hx, hy, tol):
    """The 2D hull of the ``k`` points ``(px, py)`` (sorted in place) into ``(hx, hy)``
    (capacity 2k + 2), counter-clockwise; returns its corner count: 1 (a point), 2 (a segment)
    or more (a polygon). A corner within ``tol`` (m) of its neighbours' line is dropped."""
    if k == 1:
        hx[0], hy[0] = px[0], py[0]
        return 1
    _sort(px, py, k)
    m = 0
    for i in range(k):  # lower chain, left to right
        while m >= 2 and _cross(hx[m - 2], hy[m - 2], hx[m - 1], hy[m - 1], px[i], py[i]) <= (
                tol * math.hypot(px[i] - hx[m - 2], py[i] - hy[m - 2])):
            m -= 1
        hx[m], hy[m] = px[i], py[i]
        m += 1
    lower = m + 1
    for i in range(k - 2, -1, -1):  # upper chain, right to left
        while m >= lower and _cross(hx[m - 2], hy[m - 2], hx[m - 1], hy[m - 1], px[i],
                                    py[i]) <= tol * math.hypot(px[i] - hx[m - 2],
                                                               py[i] - hy[m - 2]):
            m -= 1
        hx[m], hy[m] = px[i], py[i]
        m += 1
    m -= 1  # the first point closed the chain
    if m == 2 and math.hypot(hx[1] - hx[0], hy[1] - hy[0]) <= tol:
        m = 1
    return m


@jit
def _segments(ax, ay, bx, by, tol):
    """Centroid of two segments' intersection: (found, x, y)."""
    dx, dy, ex, ey = ax[1] - ax[0], ay[1] - ay[0], bx[1] - bx[0], by[1] - by[0]
    la, lb = math.hypot(dx, dy), math.hypot(ex, ey)
    cr = dx * ey - dy * ex
    qx, qy = bx[0] - ax[0], by[0] - ay[0]
    if abs(cr) <= tol * max(la, lb):  # parallel: the overlap of their shadows on A's line
        ux, uy = dx / la, dy / la
        s0, s1 = qx * ux + qy * uy, (bx[1] - ax[0]) * ux + (by[1] - ay[0]) * uy
        lo, hi = max(0.0, min(s0, s1)), min(la, max(s0, s1))
        if lo > hi + tol:
            return False, 0.0, 0.0
        mid, offset = 0.5 * (lo + hi), 0.5 * (ux * qy - uy * qx)  # half the lines' spacing
        return True, ax[0] + mid * ux - offset * uy, ay[0] + mid * uy + offset * ux
    s, u = (qx * ey - qy * ex) / cr, (qx * dy - qy * dx) / cr
    if s * la < -tol or (s - 1.0) * la > tol or u * lb < -tol or (u - 1.0) * lb > tol:
        return False, 0.0, 0.0
    s, u = min(1.0, max(0.0, s)), min(1.0, max(0.0, u))
    return (True, 0.5 * (ax[0] + s * dx + bx[0] + u * ex),
            0.5 * (ay[0] + s * dy + by[0] + u * ey))


@jit
def _segment_polygon(ax, ay, bx, by, mb, tol):
    """Centroid (midpoint) of a segment clipped by a convex polygon (Cyrus-Beck, the polygon's
    sides pushed out by ``tol``): (found, x, y)."""
    dx, dy = ax[1] - ax[0], ay[1] - ay[0]
    lo, hi = 0.0, 1.0
    for i in range(mb):
        j = (i + 1) % mb
        ex, ey = bx[j] - bx[i], by[j] - by[i]
        start = ex * (ay[0] - by[i]) - ey * (ax[0] - bx[i]) + tol * math.hypot(ex, ey)
        rate = ex * dy - ey * dx
        if rate > 0.0:
            lo = max(lo, -start / rate)
        elif rate < 0.0:
            hi = min(hi, -start / rate)
        elif start < 0.0:
            return False, 0.0, 0.0
    if lo > hi:
        return False, 0.0, 0.0
    mid = 0.5 * (lo + hi)
    return True, ax[0] + mid * dx, ay[0] + mid * dy


@jit
def _clip(inx, iny, m, qx, qy, rx, ry, outx, outy, tol):
    """Sutherland-Hodgman: the polygon ``(inx, iny)`` of ``m`` corners cut by the half-plane
    left of ``q -> r`` pushed out by ``tol``; returns the corner count written to ``out``."""
    ex, ey = rx - qx, ry - qy
    push = tol * math.hypot(ex, ey)
    count = 0
    for i in range(m):
        j = (i + 1) % m
        fi = ex * (iny[i] - qy) - ey * (inx[i] - qx) + push
        fj = ex * (iny[j] - qy) - ey * (inx[j] - qx) + push
        if fi >= 0.0:
            outx[count], outy[count] = inx[i], iny[i]
            count += 1
        if (fi >= 0.0) != (fj >= 0.0):
            s = fi / (fi - fj)
            outx[count] = inx[i] + s * (inx[j] - inx[i])
            outy[count] = iny[i] + s * (iny[j] - iny[i])
            count += 1
    return count


@jit
def _polygon_centroid(px, py, m, tol):
    """Area centroid of a convex polygon, or its longest chord's midpoint when it is thin:
    (found, x, y)."""
    area2, sx, sy, far, f1 = 0.0, 0.0, 0.0, 0.0, 0
    for i in range(1, m):
        dx, dy = px[i] - px[0], py[i] - py[0]
        if dx * dx + dy * dy > far:
            far, f1 = dx * dx + dy * dy, i
        if i < m - 1:
            gx, gy = px[i + 1] - px[0], py[i + 1] - py[0]
            c = dx * gy - dy * gx
            area2 += c
            sx += c * (dx + gx)
            sy += c * (dy + gy)
    if 0.5 * area2 > THIN_AREA_FACTOR * tol * math.sqrt(far):
        return True, px[0] + sx / (3.0 * area2), py[0] + sy / (3.0 * area2)
    far, f2 = 0.0, f1
    for i in range(m):
        dx, dy = px[i] - px[f1], py[i] - py[f1]
        if dx * dx + dy * dy > far:
            far, f2 = dx * dx + dy * dy, i
    return True, 0.5 * (px[f1] + px[f2]), 0.5 * (py[f1] + py[f2])


@jit
def _polygons(ax, ay, ma, bx, by, mb, c1x, c1y, c2x, c2y, tol):
    """Centroid of two convex polygons' intersection: (found, x, y)."""
    for i in range(ma):
        c1x[i], c1y[i] = ax[i], ay[i]
    m = ma
    for i in range(mb):
        j = (i + 1) % mb
        m = _clip(c1x, c1y, m, bx[i], by[i], bx[j], by[j], c2x, c2y, tol)
        if m == 0:
            return False, 0.0, 0.0
        c1x, c1y, c2x, c2y = c2x, c2y, c1x, c1y
    return _polygon_centroid(c1x, c1y, m, tol)


@jit
def region_centroid(ax, ay, ma, bx, by, mb, c1x, c1y, c2x, c2y, tol):
    """Centroid of the intersection of two 2D hulls (``ma``, ``mb`` corners; module
    docstring), slack ``tol`` (m); clip buffers ``c1``, ``c2`` of ma + mb + 2 entries:
    (found, x, y). Not found only when rounding left the two hulls apart."""
    if ma > mb:
        ax, ay, ma, bx, by, mb = bx, by, mb, ax, ay, ma
    if ma == 1:
        if mb == 1:
            return True, 0.5 * (ax[0] + bx[0]), 0.5 * (ay[0] + by[0])
        return True, ax[0], ay[0]
    if ma == 2:
        if mb == 2:
            return _segments(ax, ay, bx, by, tol)
        return _segment_polygon(ax, ay, bx, by, mb, tol)
    return _polygons(ax, ay, ma, bx, by, mb, c1x, c1y, c2x, c2y, tol)
