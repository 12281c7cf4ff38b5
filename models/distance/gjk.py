"""GJK between two convex polytopes in A's frame, with a Voronoi-region simplex solver
(compiled row functions, :mod:`impactnet.models.compiled`).

The Minkowski difference ``A - B`` is searched for its point ``v`` closest to the origin
(Gilbert, Johnson and Keerthi 1988): each iteration adds the support pair ``w = s_A(-v) -
s_B(v)`` to the simplex, and the sub-algorithm replaces the simplex by the smallest face of it
that holds its point closest to the origin (Ericson, *Real-Time Collision Detection*, 5.1.5 and
5.1.6: the point's Voronoi region is found from dot products, no division until the region is
known). A flat simplex (area or volume below :data:`~.tolerances.FLAT_SIMPLEX_REL`) answers with
its faces. A face answer's ``v`` is the face plane's normal times its offset, so that the
closest direction comes from the cross product of the face's edges, not from a short ``v``.

Termination on polytopes: the support pair is already in the simplex (nothing nearer exists),
or ``|v|^2 - v . w`` is below :data:`~.tolerances.GJK_PROGRESS_REL` ``|v|^2``, or ``|v|`` no
longer shrinks (rounding), or the simplex is a tetrahedron holding the origin, or ``|v|`` is
below the touch tolerance.

Scratch (a row's ``work`` array, float64, :data:`GJK_SLOTS` entries): simplex points ``w``
(4, 3), their points on A and on B (4, 3) each, barycentric weights (4,), the vertex indices
on A and on B (4,) each (as floats).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compiled import jit
from impactnet.models.distance.tolerances import (
    FLAT_SIMPLEX_REL,
    GJK_MAX_ITERATIONS,
    GJK_PROGRESS_REL,
)

#: Offsets of the scratch's blocks (module docstring) and its length.
W, PA, PB, LAM, IA, IB = 0, 12, 24, 36, 40, 44
GJK_SLOTS = 48
#: GJK's answers: the hulls are apart (``v`` is their gap), or they touch or overlap.
SEPARATED, COLLIDING = 0, 1


@jit
def support_index(vertices, start, stop, dx, dy, dz):
    """Index in ``[start, stop)`` of the vertex of ``vertices`` (V, 3) furthest along
    ``(dx, dy, dz)``; the first one of equals."""
    best, k = -np.inf, start
    for i in range(start, stop):
        s = vertices[i, 0] * dx + vertices[i, 1] * dy + vertices[i, 2] * dz
        if s > best:
            best, k = s, i
    return k


@jit
def _edge(w, i, j):
    """``w[j] - w[i]`` of the simplex ``w`` (3 floats a point)."""
    return w[3 * j] - w[3 * i], w[3 * j + 1] - w[3 * i + 1], w[3 * j + 2] - w[3 * i + 2]


@jit
def _dot(w, i, x, y, z):
    """``w[i] . (x, y, z)``."""
    return w[3 * i] * x + w[3 * i + 1] * y + w[3 * i + 2] * z


@jit
def _norm2(w, i, j, k, li, lj, lk):
    """``|li w[i] + lj w[j] + lk w[k]|^2``."""
    x = li * w[3 * i] + lj * w[3 * j] + lk * w[3 * k]
    y = li * w[3 * i + 1] + lj * w[3 * j + 1] + lk * w[3 * k + 1]
    z = li * w[3 * i + 2] + lj * w[3 * j + 2] + lk * w[3 * k + 2]
    return x * x + y * y + z * z


@jit
def _segment(w, i, j):
    """Weights (on i, on j) of the point of segment ``w[i] w[j]`` closest to the origin."""
    ex, ey, ez = _edge(w, i, j)
    ee = ex * ex + ey * ey + ez * ez
    if ee <= 0.0:
        return 1.0, 0.0
    s = min(1.0, max(0.0, -_dot(w, i, ex, ey, ez) / ee))
    return 1.0 - s, s


@jit
def _flat_triangle(w, i, j, k):
    """Weights of the closest point on a flat triangle: the best of its three edges."""
    li, lj = _segment(w, i, j)
    best, out = _norm2(w, i, j, k, li, lj, 0.0), (li, lj, 0.0)
    li, lk = _segment(w, i, k)
    if _norm2(w, i, j, k, li, 0.0, lk) < best:
        best, out = _norm2(w, i, j, k, li, 0.0, lk), (li, 0.0, lk)
    lj, lk = _segment(w, j, k)
    if _norm2(w, i, j, k, 0.0, lj, lk) < best:
        out = (0.0, lj, lk)
    return out


@jit
def _triangle(w, i, j, k):
    """Weights (on i, j, k) of the point of triangle ``w[i] w[j] w[k]`` closest to the
    origin, and whether it lies inside the face (Ericson 5.1.5)."""
    # ---- edges from the first corner, and the flat-triangle guard ----------------------------
    abx, aby, abz = _edge(w, i, j)
    acx, acy, acz = _edge(w, i, k)
    nx, ny, nz = aby * acz - abz * acy, abz * acx - abx * acz, abx * acy - aby * acx
    ab2, ac2 = abx * abx + aby * aby + abz * abz, acx * acx + acy * acy + acz * acz
    if nx * nx + ny * ny + nz * nz <= FLAT_SIMPLEX_REL * ab2 * ac2:
        li, lj, lk = _flat_triangle(w, i, j, k)
        return li, lj, lk, False
    # ---- vertex and edge regions, from dot products ------------------------------------------
    d1, d2 = -_dot(w, i, abx, aby, abz), -_dot(w, i, acx, acy, acz)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0, False
    d3, d4 = -_dot(w, j, abx, aby, abz), -_dot(w, j, acx, acy, acz)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0, False
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        s = d1 / (d1 - d3)
        return 1.0 - s, s, 0.0, False
    d5, d6 = -_dot(w, k, abx, aby, abz), -_dot(w, k, acx, acy, acz)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0, False
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        s = d2 / (d2 - d6)
        return 1.0 - s, 0.0, s, False
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - s, s, False
    # ---- inside the face ---------------------------------------------------------------------
    den = va + vb + vc
    return va / den, vb / den, vc / den, True


@jit
def _tetrahedron(w, lam):
    """Weights ``lam`` (4,) of the point of the tetrahedron ``w`` (4 points) closest to the
    origin; returns (inside, on a face's interior). Each face with the origin beyond it (or
    every face of a flat tetrahedron) is a candidate; inside when none is."""
    # ---- which faces see the origin (volume weights kept for the inside answer) -------------
    beyond = 0
    for l in range(4):
        i, j, k = (l + 1) % 4, (l + 2) % 4, (l + 3) % 4
        ex, ey, ez = _edge(w, i, j)
        fx, fy, fz = _edge(w, i, k)
        gx, gy, gz = _edge(w, i, l)
        nx, ny, nz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
        side_o, side_l = -_dot(w, i, nx, ny, nz), nx * gx + ny * gy + nz * gz
        flat = side_l * side_l <= FLAT_SIMPLEX_REL * (nx * nx + ny * ny + nz * nz) * (
            gx * gx + gy * gy + gz * gz)
        if flat or side_o * side_l <= 0.0:
            beyond |= 1 << l
        else:
            lam[l] = side_o / side_l  # origin on l's side: l's share of the volume
    if beyond == 0:
        return True, False
    # ---- the nearest of the candidate faces --------------------------------------------------
    best, face, chosen = np.inf, False, (0, 1.0, 0.0, 0.0)
    for l in range(4):
        if beyond & (1 << l):
            i, j, k = (l + 1) % 4, (l + 2) % 4, (l + 3) % 4
            li, lj, lk, on_face = _triangle(w, i, j, k)
            if _norm2(w, i, j, k, li, lj, lk) < best:
                best, face = _norm2(w, i, j, k, li, lj, lk), on_face
                chosen = (l, li, lj, lk)
    l, li, lj, lk = chosen
    lam[l], lam[(l + 1) % 4], lam[(l + 2) % 4], lam[(l + 3) % 4] = 0.0, li, lj, lk
    return False, face


@jit
def _solve(work, count):
    """Weights of the simplex's point closest to the origin into ``work[LAM:]``, the simplex
    then reduced to the points of positive weight; returns (count, inside, face)."""
    w, lam = work, work[LAM:LAM + 4]  # w: the simplex, 3 floats a point from W = 0
    inside, face = False, False
    if count == 1:
        lam[0] = 1.0
    elif count == 2:
        lam[0], lam[1] = _segment(w, 0, 1)
    elif count == 3:
        lam[0], lam[1], lam[2], face = _triangle(w, 0, 1, 2)
    else:
        inside, face = _tetrahedron(w, lam)
    if inside:
        return count, True, False
    kept = 0
    for m in range(count):
        if lam[m] > 0.0:
            if kept != m:
                for block in (W, PA, PB):
                    for c in range(3):
                        work[block + 3 * kept + c] = work[block + 3 * m + c]
                work[IA + kept], work[IB + kept] = work[IA + m], work[IB + m]
                lam[kept] = lam[m]
            kept += 1
    return kept, False, face and kept == 3


@jit
def _closest(work, count, face):
    """The simplex's point ``v`` closest to the origin: its weights' point, or for a face the
    plane's normal times its offset (exact direction however short ``v`` is)."""
    w = work  # the simplex, 3 floats a point from W = 0
    if face:
        ex, ey, ez = _edge(w, 0, 1)
        fx, fy, fz = _edge(w, 0, 2)
        nx, ny, nz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
        scale = _dot(w, 0, nx, ny, nz) / (nx * nx + ny * ny + nz * nz)
        return scale * nx, scale * ny, scale * nz
    vx, vy, vz = 0.0, 0.0, 0.0
    for m in range(count):
        vx += work[LAM + m] * w[3 * m]
        vy += work[LAM + m] * w[3 * m + 1]
        vz += work[LAM + m] * w[3 * m + 2]
    return vx, vy, vz


@jit
def _add_support(vertices, sa, ea, sb, eb, t, r, vx, vy, vz, work, count):
    """Add the support pair of ``-v`` on A and ``v`` on B (B's vertices placed by ``t``,
    ``r``) at slot ``count``; returns (already in the simplex, v . w)."""
    ia = support_index(vertices, sa, ea, -vx, -vy, -vz)
    ib = support_index(vertices, sb, eb, r[0, 0] * vx + r[1, 0] * vy + r[2, 0] * vz,
                       r[0, 1] * vx + r[1, 1] * vy + r[2, 1] * vz,
                       r[0, 2] * vx + r[1, 2] * vy + r[2, 2] * vz)
    for m in range(count):
        if work[IA + m] == ia and work[IB + m] == ib:
            return True, 0.0
    vw = 0.0
    for c in range(3):
        b = (t[c] + r[c, 0] * vertices[ib, 0] + r[c, 1] * vertices[ib, 1]
             + r[c, 2] * vertices[ib, 2])
        work[PA + 3 * count + c] = vertices[ia, c]
        work[PB + 3 * count + c] = b
        work[W + 3 * count + c] = vertices[ia, c] - b
    vw = vx * work[W + 3 * count] + vy * work[W + 3 * count + 1] + vz * work[W + 3 * count + 2]
    work[IA + count], work[IB + count] = ia, ib
    return False, vw


@jit
def gjk(vertices, sa, ea, sb, eb, t, r, touch, work):
    """GJK (module docstring) between A's vertices ``[sa, ea)`` and B's ``[sb, eb)`` of
    ``vertices`` (V, 3), body frames, metres; B placed in A's frame by ``t`` (3,) and ``r``
    (3, 3). ``touch`` (m): below it the hulls touch.

    Returns
    -------
    (state, count, face, vx, vy, vz)
        :data:`SEPARATED` or :data:`COLLIDING`; the simplex's size; whether ``v`` is a face's
        (its direction exact to rounding); ``v`` (m), A's point minus B's point of the closest
        pair (A's frame). The simplex, its points on A and B and their weights stay in
        ``work``.
    """
    # ---- start from the difference of the first vertices ------------------------------------
    for c in range(3):
        work[W + c] = vertices[sa, c] - (t[c] + r[c, 0] * vertices[sb, 0]
                                         + r[c, 1] * vertices[sb, 1] + r[c, 2] * vertices[sb, 2])
    vx, vy, vz = work[W], work[W + 1], work[W + 2]
    vv = np.inf  # no simplex yet: the first support point is always taken
    count, face = 0, False
    # ---- iterate: add the support pair, reduce the simplex, stop when nothing improves -------
    for _ in range(GJK_MAX_ITERATIONS):
        repeated, vw = _add_support(vertices, sa, ea, sb, eb, t, r, vx, vy, vz, work, count)
        if repeated or (count > 0 and vv - vw <= GJK_PROGRESS_REL * vv):
            break
        count, inside, face = _solve(work, count + 1)
        if inside:
            return COLLIDING, count, False, 0.0, 0.0, 0.0
        vx, vy, vz = _closest(work, count, face)
        shorter = vx * vx + vy * vy + vz * vz
        if shorter <= touch * touch:
            return COLLIDING, count, face, vx, vy, vz
        if shorter >= vv:
            break
        vv = shorter
    return SEPARATED, count, face, vx, vy, vz
