"""The distance query's compiled kernels: the row function :func:`gap_row` and the batch
kernels over N poses of one pair of hulls (serial and parallel), with their warm-up.

A row (A's frame, metres): GJK (:mod:`.gjk`) finds the distance and the closest direction;
separated hulls then get the closest region's centroid (:mod:`.region`): the midpoint, and the
points on A and on B half the distance along the direction on either side of it (the closest
region's mid-plane passes through GJK's witness points' midpoint). Touching or overlapping
hulls (GJK's ``|v|`` below :data:`~.tolerances.TOUCH_REL` x scale, or the origin inside its
tetrahedron) answer distance 0 and direction 0, no penetration depth (the contact solver gives
it), and a point of both hulls: touching through a face of the difference (GJK's last simplex
a triangle whose plane supports both hulls), the touching region's centroid, so that the point
is continuous up to and at the moment of contact; else GJK's witness points (equal for an
overlap, within the touch tolerance when touching) and their midpoint.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compiled import jit, numba, parallel_jit
from impactnet.models.distance.gjk import GJK_SLOTS, LAM, PA, PB, SEPARATED, gjk
from impactnet.models.distance.region import hull2d, plane_basis, region_centroid, region_slots
from impactnet.models.distance.tolerances import (
    DIRECTION_NOISE,
    PLANE_REL,
    SUPPORT_CAP_REL,
    SUPPORT_REL,
    TOUCH_REL,
)

#: Rows per block of the parallel kernel (one scratch array per block).
BLOCK_ROWS = 64


@jit
def scratch_slots(max_vertices):
    """Length of a row's float64 scratch for hulls of up to ``max_vertices`` corners."""
    return GJK_SLOTS + region_slots(max_vertices)


@jit
def _placed(vertices, i, t, r, placed):
    """Corner ``i`` in A's frame: placed by ``t``, ``r`` (B's) or as it is (A's)."""
    x, y, z = vertices[i, 0], vertices[i, 1], vertices[i, 2]
    if not placed:
        return x, y, z
    return (t[0] + r[0, 0] * x + r[0, 1] * y + r[0, 2] * z,
            t[1] + r[1, 0] * x + r[1, 1] * y + r[1, 2] * z,
            t[2] + r[2, 0] * x + r[2, 1] * y + r[2, 2] * z)


@jit
def _support_set(vertices, start, stop, t, r, placed, n, sign, frame, work, at, cap):
    """The corners of one hull within the slack of its extreme along ``sign * n``, projected
    on the plane: ``frame`` = (slack, origin (3), e1 (3), e2 (3)); coordinates into
    ``work[at:at + cap]`` (x) and ``work[at + cap:at + 2 cap]`` (y). Returns their count."""
    extreme = -np.inf
    for i in range(start, stop):
        x, y, z = _placed(vertices, i, t, r, placed)
        extreme = max(extreme, sign * (x * n[0] + y * n[1] + z * n[2]))
    count = 0
    for i in range(start, stop):
        x, y, z = _placed(vertices, i, t, r, placed)
        if sign * (x * n[0] + y * n[1] + z * n[2]) >= extreme - frame[0]:
            x, y, z = x - frame[1], y - frame[2], z - frame[3]
            work[at + count] = x * frame[4] + y * frame[5] + z * frame[6]
            work[at + cap + count] = x * frame[7] + y * frame[8] + z * frame[9]
            count += 1
    return count


@jit
def _hulls_centroid(work, cap, ka, kb, flat):
    """Centroid of the intersection of the support sets' 2D hulls (``ka``, ``kb`` points at
    the region scratch's start), ``flat`` the plane slack (m): (found, x, y)."""
    wide = 2 * cap + 2
    bufs = work[GJK_SLOTS:GJK_SLOTS + region_slots(cap)]
    hull, clip = bufs[4 * cap:4 * cap + 4 * wide], bufs[4 * cap + 4 * wide:]
    ma = hull2d(bufs[:cap], bufs[cap:2 * cap], ka, hull[:wide], hull[wide:2 * wide], flat)
    mb = hull2d(bufs[2 * cap:3 * cap], bufs[3 * cap:4 * cap], kb, hull[2 * wide:3 * wide],
                hull[3 * wide:], flat)
    return region_centroid(hull[:wide], hull[wide:2 * wide], ma, hull[2 * wide:3 * wide],
                           hull[3 * wide:], mb, clip[:wide], clip[wide:2 * wide],
                           clip[2 * wide:3 * wide], clip[3 * wide:], flat)


@jit
def _region(vertices, sa, ea, sb, eb, t, r, n, scale, noise, origin, work):
    """The closest region's centroid (A's frame) in the plane across ``n`` through ``origin``
    (3 floats: GJK's midpoint, on the mid-plane of a flat region); ``scale`` the pair's (m),
    ``noise`` the direction's share of the support slack: (found, point (3 floats)). A single
    corner on either side is the region (no hulls)."""
    tol = scale * (SUPPORT_REL + noise)
    e = plane_basis(n[0], n[1], n[2])
    frame = (tol, origin[0], origin[1], origin[2], e[0], e[1], e[2], e[3], e[4], e[5])
    cap = (work.shape[0] - GJK_SLOTS - 16) // 20
    at_a, at_b = GJK_SLOTS, GJK_SLOTS + 2 * cap
    ka = _support_set(vertices, sa, ea, t, r, False, n, 1.0, frame, work, at_a, cap)
    kb = _support_set(vertices, sb, eb, t, r, True, n, -1.0, frame, work, at_b, cap)
    found = True
    if ka == 1 and kb == 1:
        cx, cy = 0.5 * (work[at_a] + work[at_b]), 0.5 * (work[at_a + cap] + work[at_b + cap])
    elif ka == 1:
        cx, cy = work[at_a], work[at_a + cap]
    elif kb == 1:
        cx, cy = work[at_b], work[at_b + cap]
    else:
        found, cx, cy = _hulls_centroid(work, cap, ka, kb, scale * PLANE_REL)
    return found, (origin[0] + cx * e[0] + cy * e[3], origin[1] + cx * e[1] + cy * e[4],
                   origin[2] + cx * e[2] + cy * e[5])


@jit
def _witnesses(work, count):
    """GJK's closest points on A and on B (A's frame): two triples of floats."""
    ax = ay = az = bx = by = bz = 0.0
    for m in range(count):
        lam = work[LAM + m]
        ax += lam * work[PA + 3 * m]
        ay += lam * work[PA + 3 * m + 1]
        az += lam * work[PA + 3 * m + 2]
        bx += lam * work[PB + 3 * m]
        by += lam * work[PB + 3 * m + 1]
        bz += lam * work[PB + 3 * m + 2]
    return (ax, ay, az), (bx, by, bz)


@jit
def gap_row(vertices, vertex_start, hull_size, hull_a, hull_b, t, r, work, row,
            distance, point_a, point_b, point, direction):
    """The gap between two hulls of the tables, written at ``row`` (A's frame).

    Parameters
    ----------
    vertices, vertex_start, hull_size : ndarray
        The flat hull tables (:class:`~impactnet.models.distance.tables.HullTables`): (V, 3)
        float64 m, (H + 1,) int64, (H, 2) float64 m.
    hull_a, hull_b : int
        The two hulls' indices.
    t : ndarray, shape (3,)
        B's position in A's frame, ``R_A^T (p_B - p_A)`` (m).
    r : ndarray, shape (3, 3)
        B's rotation in A's frame, ``R_A^T R_B``.
    work : ndarray of float64, shape (:func:`scratch_slots` (most corners of a hull),)
        Scratch, one per thread.
    row : int
        The output row.
    distance : ndarray, shape (n,)
        The gap (m), > 0 when separated; 0 when touching or overlapping.
    point_a, point_b, point : ndarray, shape (n, 3)
        The closest points on A, on B and their midpoint (m, A's frame): the closest region's
        centroid where it is not unique. Touching or overlapping: a point of both hulls.
    direction : ndarray, shape (n, 3)
        Unit direction from A towards B (A's frame); 0 when touching or overlapping.

    Returns
    -------
    bool
        Whether the hulls touch or overlap.
    """
    # ---- GJK: the distance, the closest direction, the witness points ------------------------
    sa, ea, sb, eb = (vertex_start[hull_a], vertex_start[hull_a + 1], vertex_start[hull_b],
                      vertex_start[hull_b + 1])
    scale = max(hull_size[hull_a, 0], hull_size[hull_b, 0])
    state, count, face, vx, vy, vz = gjk(vertices, sa, ea, sb, eb, t, r, TOUCH_REL * scale, work)
    wa, wb = _witnesses(work, count)
    middle = (0.5 * (wa[0] + wb[0]), 0.5 * (wa[1] + wb[1]), 0.5 * (wa[2] + wb[2]))
    # ---- the closest region's centroid; the slack grows by the rounding of a direction that
    # came from a short v (not a face's normal); touching along a face: that face's region ----
    if state == SEPARATED:
        gap = math.sqrt(vx * vx + vy * vy + vz * vz)
        n = (-vx / gap, -vy / gap, -vz / gap)
        noise = 0.0 if face else _direction_noise(hull_size, hull_a, hull_b, t, gap)
        found, mid = _region(vertices, sa, ea, sb, eb, t, r, n, scale, noise, middle, work)
    else:
        gap, n, found, mid = 0.0, (0.0, 0.0, 0.0), False, middle
        if count == 3 and face:
            plane, n = _touch_normal(vertices, sa, ea, sb, eb, t, r, scale * SUPPORT_REL, work)
            if plane:
                found, mid = _region(vertices, sa, ea, sb, eb, t, r, n, scale, 0.0, middle,
                                     work)
            n = (0.0, 0.0, 0.0)
    # ---- outputs -----------------------------------------------------------------------------
    _write(row, gap, n, found, mid, wa, wb, distance, point_a, point_b, point, direction)
    return state != SEPARATED


@jit
def _direction_noise(hull_size, hull_a, hull_b, t, gap):
    """The support slack's share (x scale) for a direction from a short ``v``: its rounding
    over the gap, twice (:data:`~.tolerances.DIRECTION_NOISE`)."""
    reach = hull_size[hull_a, 1] + hull_size[hull_b, 1] + math.sqrt(
        t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
    return min(2.0 * DIRECTION_NOISE * reach / gap, SUPPORT_CAP_REL)


@jit
def _write(row, gap, n, found, mid, wa, wb, distance, point_a, point_b, point, direction):
    """Row ``row`` of the outputs: the midpoint ``mid`` and half the gap either side along
    ``n``, or GJK's points ``wa``, ``wb`` and their midpoint where rounding lost the region or
    the hulls overlap."""
    distance[row] = gap
    for c in range(3):
        direction[row, c] = n[c]
        if found:
            point[row, c] = mid[c]
            point_a[row, c] = mid[c] - 0.5 * gap * n[c]
            point_b[row, c] = mid[c] + 0.5 * gap * n[c]
        else:
            point[row, c] = 0.5 * (wa[c] + wb[c])
            point_a[row, c], point_b[row, c] = wa[c], wb[c]


@jit
def _heights(vertices, start, stop, t, r, placed, n):
    """The lowest and highest corner of a hull along ``n`` (m)."""
    lo, hi = np.inf, -np.inf
    for i in range(start, stop):
        x, y, z = _placed(vertices, i, t, r, placed)
        h = x * n[0] + y * n[1] + z * n[2]
        lo, hi = min(lo, h), max(hi, h)
    return lo, hi


@jit
def _touch_normal(vertices, sa, ea, sb, eb, t, r, slack, work):
    """The unit normal, from A towards B, of GJK's last simplex, a triangle through the
    origin's touch ball: (whether it is a touching plane, normal). It is one when, on one of
    its sides, B's lowest corner is not below A's highest by more than ``slack`` (m); a
    triangle across the inside of the difference is not."""
    ex, ey, ez = work[3] - work[0], work[4] - work[1], work[5] - work[2]
    fx, fy, fz = work[6] - work[0], work[7] - work[1], work[8] - work[2]
    nx, ny, nz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    n = (nx / norm, ny / norm, nz / norm)
    lo_a, hi_a = _heights(vertices, sa, ea, t, r, False, n)
    lo_b, hi_b = _heights(vertices, sb, eb, t, r, True, n)
    if lo_b - hi_a >= lo_a - hi_b:
        return lo_b - hi_a >= -slack, n
    return lo_a - hi_b >= -slack, (-n[0], -n[1], -n[2])


@jit
def _one_pose(tables, hulls, poses, i, work, t, r, outs):
    """Row ``i`` of a batch: B's pose in A's frame, the row function, the answer back in the
    world frame. ``tables`` = (vertices, vertex_start, hull_size); ``hulls`` = (A, B);
    ``poses`` = (p_A (n, 3), R_A (n, 3, 3), p_B, R_B); ``outs`` = (distance, point_a,
    point_b, point, direction, colliding)."""
    pa, ra, pb, rb = poses
    distance, point_a, point_b, point, direction, colliding = outs
    # ---- relative pose: t = R_A^T (p_B - p_A), r = R_A^T R_B ---------------------------------
    for j in range(3):
        t[j] = 0.0
        for c in range(3):
            t[j] += ra[i, c, j] * (pb[i, c] - pa[i, c])
        for k in range(3):
            r[j, k] = ra[i, 0, j] * rb[i, 0, k] + ra[i, 1, j] * rb[i, 1, k] + ra[i, 2, j] * rb[
                i, 2, k]
    colliding[i] = gap_row(tables[0], tables[1], tables[2], hulls[0], hulls[1], t, r, work, i,
                           distance, point_a, point_b, point, direction)
    # ---- back to the world frame: x <- R_A x + p_A, directions rotated only ------------------
    for out, shift in ((point_a, 1.0), (point_b, 1.0), (point, 1.0), (direction, 0.0)):
        x, y, z = out[i, 0], out[i, 1], out[i, 2]
        for c in range(3):
            out[i, c] = ra[i, c, 0] * x + ra[i, c, 1] * y + ra[i, c, 2] * z + shift * pa[i, c]


@jit
def _largest_hull(vertex_start):
    most = 1
    for h in range(vertex_start.shape[0] - 1):
        most = max(most, vertex_start[h + 1] - vertex_start[h])
    return most


@jit
def gap_rows_serial(tables, hulls, poses, start, stop, outs):
    """Rows ``[start, stop)`` of a batch, one after the other (arguments: :func:`_one_pose`)."""
    work = np.empty(scratch_slots(_largest_hull(tables[1])))
    t, r = np.empty(3), np.empty((3, 3))
    for i in range(start, stop):
        _one_pose(tables, hulls, poses, i, work, t, r, outs)


@parallel_jit
def gap_rows_parallel(tables, hulls, poses, start, stop, outs):
    """Rows ``[start, stop)`` of a batch in blocks of :data:`BLOCK_ROWS` over the kernel
    threads, one scratch per block (arguments: :func:`_one_pose`)."""
    slots = scratch_slots(_largest_hull(tables[1]))
    blocks = (stop - start + BLOCK_ROWS - 1) // BLOCK_ROWS
    for block in numba.prange(blocks):
        work = np.empty(slots)
        t, r = np.empty(3), np.empty((3, 3))
        first = start + block * BLOCK_ROWS
        for i in range(first, min(stop, first + BLOCK_ROWS)):
            _one_pose(tables, hulls, poses, i, work, t, r, outs)
