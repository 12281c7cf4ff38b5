"""The face contact of two convex polyhedra, compiled: centre of pressure, depth, incident
feature and manifold of one row (:func:`face_region`), in the reference body's frame
(docs/design.md's rule, as in :mod:`impactnet.models.box.pressure`).

The reference face (outward normal ``n``, plane ``n . x = h``) belongs to the reference hull;
the other hull is incident, its vertices given in the reference hull's frame. Depth below the
reference plane is ``d = h - n . x``, the pressure ``p = d + tau`` with the box solver's floor
``tau`` (:data:`impactnet.models.box.pressure.PRESSURE_FLOOR_REL` of the pair's scale).

* Region: every fan triangle of every incident face that looks towards the reference face
  (``m . n < 0``) and reaches ``p >= 0``, in the reference plane's coordinates (u, w, p),
  clipped to ``p >= 0`` and to the reference face's side planes (Sutherland-Hodgman, one side
  after the other); the integrals of the pressure over each clipped triangle summed triangle
  by triangle (closed forms for a linear pressure over a triangle of area S with vertices a,
  b, c, fanned from the polygon's first vertex)::

      int p    = S (pa + pb + pc) / 3
      int x p  = S / 12 [a (2pa + pb + pc) + b (pa + 2pb + pc) + c (pa + pb + 2pc)]
      int p^2  = S / 6 (pa^2 + pb^2 + pc^2 + pa pb + pb pc + pc pa)

* Point: the pressure-weighted mean of the mid-surface points ``y - n d / 2``; a row whose
  region is empty takes the incident hull's deepest vertex, moved half its depth back.
* Depth: the separating-axis overlap, or the region's deepest point where that is shallower
  by more than :data:`impactnet.models.box.pressure.REGION_DEPTH_TOL_REL` (the incident hull
  hangs past the reference face's rim).
* Incident feature: of the incident faces that hold the deepest vertex, the one most
  anti-parallel to ``n``; its vertices within :data:`impactnet.models.box.manifold.SNAP_TOL_REL`
  of ``p >= 0`` name a face (3 or more), an edge (2) or a vertex (1).
* Manifold: that incident face clipped like the region, at most
  :data:`impactnet.models.contacts.MAX_MANIFOLD_POINTS` of its vertices (evenly spread along
  the polygon where it has more), on the mid-surface.

Each clip, integral and sum is the NumPy solver's expression in its order (the vectorised
clip the NumPy solver ran on every polygon at once, here one polygon at a time), so the answers
keep their bits.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL, REGION_DEPTH_TOL_REL, SNAP_TOL_REL
from impactnet.models.compiled import jit
from impactnet.models.compound.sat_faces import maximum
from impactnet.models.contacts import MAX_MANIFOLD_POINTS

#: A side plane (unit normal in the face's plane) whose value at the polygon's bounding
#: circle's centre exceeds the circle's radius by more than this (x the magnitudes the values
#: are computed from, metres) has every vertex strictly inside: 4500 ulps, far above their
#: rounding.
CIRCLE_TOL_REL = 1e-12


class FaceWork(NamedTuple):
    """Scratch of one thread's face contacts (sized by the largest hulls of the two tables)."""

    x_inc: np.ndarray  # (V, 3) A's vertices in B's frame (B's face is the reference)
    normals_inc: np.ndarray  # (F, 3) A's face normals in B's frame
    uwp: np.ndarray  # (V, 3) the incident vertices' (u, w, p)
    polygons: np.ndarray  # (2, P, 3) a polygon and its clip, P = 2 L + 8 (L sides cut by L)
    value: np.ndarray  # (P,) the clip's plane values
    manifold: np.ndarray  # (8, 3) the manifold, reference frame
    manifold_depth: np.ndarray  # (8,)


@jit
def face_work(vertices, faces, loop):
    """A :class:`FaceWork` for hulls of at most these counts (``loop``: sides of a face)."""
    size = 2 * loop + 8
    return FaceWork(np.empty((vertices, 3)), np.empty((faces, 3)), np.empty((vertices, 3)),
                    np.empty((2, size, 3)), np.empty(size), np.zeros((MAX_MANIFOLD_POINTS, 3)),
                    np.zeros(MAX_MANIFOLD_POINTS))


# --- Stages (plain arrays: a table's arrays are read out of it once per call of the rows) -------


@jit
def _plane_coordinates(normals, offsets, frames, f, x_inc, nv, tau, uwp):
    """``uwp``: each incident vertex's (u, w) in face f's frame and its pressure; the deepest
    vertex (the first of equal pressures) and its pressure."""
    n0, n1, n2 = normals[f, 0], normals[f, 1], normals[f, 2]
    h = offsets[f]
    o0, o1, o2 = frames[f, 0, 0], frames[f, 0, 1], frames[f, 0, 2]
    u0, u1, u2 = frames[f, 1, 0], frames[f, 1, 1], frames[f, 1, 2]
    w0, w1, w2 = frames[f, 2, 0], frames[f, 2, 1], frames[f, 2, 2]
    top, top_p = 0, -np.inf
    for k in range(nv):
        x0, x1, x2 = x_inc[k, 0], x_inc[k, 1], x_inc[k, 2]
        r0, r1, r2 = x0 - o0, x1 - o1, x2 - o2
        uwp[k, 0] = r0 * u0 + r1 * u1 + r2 * u2
        uwp[k, 1] = r0 * w0 + r1 * w1 + r2 * w2
        p = (h - (x0 * n0 + x1 * n1 + x2 * n2)) + tau
        uwp[k, 2] = p
        if p > top_p:
            top, top_p = k, p
    return top, top_p


@jit
def _incident_feature(n, vertex_start, face_start, edge_start, loop_start, loop_vertex,
                      vertex_face_start, vertex_face, adjacency_start, adjacency_vertex,
                      adjacency_edge, hi, normals_inc, top, tau, scale, uwp):
    """(feature id, rank, incident face) (module docstring); ``top`` the deepest vertex, ``n``
    the reference normal (3), the incident hull ``hi`` of the arrays' table."""
    vi0, fi0 = vertex_start[hi], face_start[hi]
    facing, face = np.inf, -1
    for s in range(vertex_face_start[vi0 + top], vertex_face_start[vi0 + top + 1]):
        g = vertex_face[s]
        value = normals_inc[g, 0] * n[0] + normals_inc[g, 1] * n[1] + normals_inc[g, 2] * n[2]
        if value < facing:
            facing, face = value, g
    touching, first, second, first_depth, second_depth = 0, -1, -1, -np.inf, -np.inf
    for s in range(loop_start[fi0 + face], loop_start[fi0 + face + 1]):
        depth = uwp[loop_vertex[s], 2] - tau  # the two deepest, the first in loop order on ties
        if depth >= -(SNAP_TOL_REL * scale):
            touching += 1
        if depth > first_depth:
            second, second_depth = first, first_depth
            first, first_depth = s, depth
        elif depth > second_depth:
            second, second_depth = s, depth
    first, second = loop_vertex[first], loop_vertex[second]
    edge = -1
    for s in range(adjacency_start[vi0 + first], adjacency_start[vi0 + first + 1]):
        if adjacency_vertex[s] == second:
            edge = adjacency_edge[s]
    faces = face_start[hi + 1] - fi0
    if touching >= 3:
        return face, 3, face
    if touching == 2 and edge >= 0:
        return faces + edge, 2, face
    return faces + (edge_start[hi + 1] - edge_start[hi]) + first, 1, face


@jit
def _bounding_circle(polygons, src, size):
    """(u, w, radius) of a circle around the polygon ``polygons[src, :size]``: its vertices'
    mean and their largest distance from it (m)."""
    cu = cw = 0.0
    for i in range(size):
        cu += polygons[src, i, 0]
        cw += polygons[src, i, 1]
    cu, cw = cu / size, cw / size
    radius = 0.0
    for i in range(size):
        du, dw = polygons[src, i, 0] - cu, polygons[src, i, 1] - cw
        radius = max(radius, du * du + dw * dw)
    return cu, cw, math.sqrt(radius)


@jit
def _clipped_items(n, frames, planes, f, s0, s1, loop_start, loop_vertex, fi0, nfi,
                   normals_inc, inc_face, tau, work):
    """The region and the manifold (module docstring): the incident face ``inc_face``'s loop,
    then every fan triangle of every incident face that looks towards the reference face (the
    incident hull's faces from ``fi0``, ``nfi`` of them) and reaches ``p >= 0``, each clipped
    to ``p >= 0`` and to face f's sides ``planes[s0:s1]`` one after the other
    (Sutherland-Hodgman: each vertex emits itself where inside and the crossing of its outgoing
    edge where that edge crosses the plane, ``p = 0`` exactly on the pressure plane). The
    triangles' moments summed in their order and their deepest pressure; the manifold's points
    in ``work.manifold`` (mid-surface, reference frame) and depths. Returns
    (int p, int u p, int w p, int p^2, deepest pressure, manifold count)."""
    uwp, polygons, value = work.uwp, work.polygons, work.value
    manifold, manifold_depth = work.manifold, work.manifold_depth
    room = polygons.shape[1] - 1  # a convex polygon gains a vertex per cut; rounding no more
    t0 = t1 = t2 = t3 = 0.0
    deepest = -np.inf
    count = 0
    for g in range(-1, nfi):  # -1: the manifold's face
        if g < 0:
            l0, l1 = loop_start[fi0 + inc_face], loop_start[fi0 + inc_face + 1]
            items = 1
        elif normals_inc[g, 0] * n[0] + normals_inc[g, 1] * n[1] + normals_inc[g, 2] * n[2] < 0.0:
            l0, l1 = loop_start[fi0 + g], loop_start[fi0 + g + 1]
            items = l1 - l0 - 2  # its fan triangles
        else:
            continue  # looks away from the reference face
        for item in range(items):
            if g < 0:
                size = l1 - l0
                for k in range(size):
                    for c in range(3):
                        polygons[0, k, c] = uwp[loop_vertex[l0 + k], c]
            else:
                va, vb, vc = loop_vertex[l0], loop_vertex[l0 + item + 1], loop_vertex[l0 + item + 2]
                if not max(uwp[va, 2], uwp[vb, 2], uwp[vc, 2]) >= 0.0:
                    continue
                size = 3
                for c in range(3):
                    polygons[0, 0, c], polygons[0, 1, c] = uwp[va, c], uwp[vb, c]
                    polygons[0, 2, c] = uwp[vc, c]
            # clip: p >= 0 (k = s0 - 1), then the sides; a side whose line passes beyond the
            # polygon's bounding circle (centre cu, cw, radius, with a margin far above the
            # rounding of its values) leaves every vertex inside, as does a plane no vertex is
            # outside of: the polygon stays as it is (a many-sided face's sides, mostly)
            src = 0
            cu = cw = radius = 0.0
            circle = False
            for k in range(s0 - 1, s1):
                if size == 0:
                    break
                c0, c1, c2, c3 = 0.0, 0.0, 1.0, 0.0
                if k >= s0:
                    c0, c1, c2, c3 = planes[k, 0], planes[k, 1], planes[k, 2], planes[k, 3]
                    if not circle:
                        cu, cw, radius = _bounding_circle(polygons, src, size)
                        circle = True
                    reach = c0 * cu + c1 * cw + c3 - radius
                    if reach > CIRCLE_TOL_REL * (abs(cu) + abs(cw) + abs(c3) + radius):
                        continue
                outside = False
                for i in range(size):
                    value[i] = ((c0 * polygons[src, i, 0] + c1 * polygons[src, i, 1])
                                + c2 * polygons[src, i, 2]) + c3
                    outside = outside or value[i] < 0.0
                if not outside:
                    continue  # every vertex emits itself: the polygon as it is
                dst, kept = 1 - src, 0
                for i in range(size):
                    j = i + 1 if i + 1 < size else 0
                    inside = value[i] >= 0.0
                    if inside and kept < room:
                        for c in range(3):
                            polygons[dst, kept, c] = polygons[src, i, c]
                        kept += 1
                    if inside != (value[j] >= 0.0) and kept < room:
                        fraction = value[i] / (value[i] - value[j])
                        for c in range(3):
                            polygons[dst, kept, c] = polygons[src, i, c] + fraction * (
                                polygons[src, j, c] - polygons[src, i, c])
                        if k < s0:
                            polygons[dst, kept, 2] = 0.0
                        kept += 1
                src, size, circle = dst, kept, False
            if g < 0:  # the manifold: at most 8 vertices, evenly spread, on the mid-surface
                count = min(size, MAX_MANIFOLD_POINTS)
                manifold[:] = 0.0
                manifold_depth[:] = 0.0
                for j in range(count):
                    pick = j * size // MAX_MANIFOLD_POINTS if size > MAX_MANIFOLD_POINTS else j
                    u, w = polygons[src, pick, 0], polygons[src, pick, 1]
                    depth = maximum(polygons[src, pick, 2] - tau, 0.0)
                    manifold_depth[j] = depth
                    for c in range(3):
                        manifold[j, c] = (((frames[f, 0, c] + u * frames[f, 1, c])
                                           + w * frames[f, 2, c]) - 0.5 * depth * n[c])
                continue
            # the triangle's moments (module docstring), fanned from its first vertex
            m0 = m1 = m2 = m3 = 0.0
            au, aw, pa = polygons[src, 0, 0], polygons[src, 0, 1], polygons[src, 0, 2]
            for i in range(1, size - 1):
                bu, bw, pb = polygons[src, i, 0], polygons[src, i, 1], polygons[src, i, 2]
                cu, cw, pc = (polygons[src, i + 1, 0], polygons[src, i + 1, 1],
                              polygons[src, i + 1, 2])
                area = 0.5 * abs((bu - au) * (cw - aw) - (bw - aw) * (cu - au))
                m0 += area * (pa + pb + pc) / 3.0
                m1 += area / 12.0 * (au * (2 * pa + pb + pc) + bu * (pa + 2 * pb + pc)
                                     + cu * (pa + pb + 2 * pc))
                m2 += area / 12.0 * (aw * (2 * pa + pb + pc) + bw * (pa + 2 * pb + pc)
                                     + cw * (pa + pb + 2 * pc))
                m3 += area / 6.0 * (pa * pa + pb * pb + pc * pc + pa * pb + pb * pc + pc * pa)
            t0 += m0
            t1 += m1
            t2 += m2
            t3 += m3
            for i in range(size):
                deepest = max(deepest, polygons[src, i, 2])
    return t0, t1, t2, t3, deepest, count


@jit
def face_region(normals, offsets, frames, face_start, ref_loops, planes, hr, face,
                vertex_start, inc_faces, edge_start, loop_start, loop_vertex, vertex_face_start,
                vertex_face, adjacency_start, adjacency_vertex, adjacency_edge, hi, x_inc,
                normals_inc, sat_depth, scale, work):
    """The face contact of one row (module docstring), in the reference hull's frame.

    Parameters
    ----------
    normals, offsets, frames, face_start, ref_loops, planes
        The reference hull's table (:class:`~impactnet.models.compound.hull_stack.HullArrays`:
        face_normals, face_offsets, face_frames, face_start, loop_start, side_planes); ``hr``
        the hull, ``face`` its face (the hull's own index).
    vertex_start, ..., adjacency_edge
        The incident hull's table (vertex_start, face_start, edge_start, loop_start,
        loop_vertex, vertex_face_start, vertex_face, adjacency_start, adjacency_vertex,
        adjacency_edge); ``hi`` the hull. (Plain arrays: a table's arrays read out of its tuple
        cost a reference count each, which the kernel threads would contend for; the rows'
        kernels read them once.)
    x_inc : ndarray, shape (>= V_inc, 3)
        The incident hull's vertices in the reference frame (metres).
    normals_inc : ndarray, shape (>= F_inc, 3)
        The incident hull's face normals in the reference frame.
    sat_depth, scale : float
        The separating-axis overlap along the reference normal and the pair's scale (metres).
    work : FaceWork

    Returns
    -------
    (point (3), depth, pressure, feature, rank, manifold count), the manifold in
    ``work.manifold`` and ``work.manifold_depth``.
    """
    tau = PRESSURE_FLOOR_REL * scale
    f = face_start[hr] + face
    nv = vertex_start[hi + 1] - vertex_start[hi]
    uwp = work.uwp
    top, top_p = _plane_coordinates(normals, offsets, frames, f, x_inc, nv, tau, uwp)
    n = (normals[f, 0], normals[f, 1], normals[f, 2])
    feature, rank, inc_face = _incident_feature(
        n, vertex_start, inc_faces, edge_start, loop_start, loop_vertex, vertex_face_start,
        vertex_face, adjacency_start, adjacency_vertex, adjacency_edge, hi, normals_inc, top,
        tau, scale, uwp)
    fi0 = inc_faces[hi]
    t0, t1, t2, t3, deepest, count = _clipped_items(
        n, frames, planes, f, ref_loops[f], ref_loops[f + 1], loop_start, loop_vertex, fi0,
        inc_faces[hi + 1] - fi0, normals_inc, inc_face, tau, work)
    found = t0 > 0.0
    if found:
        offset = maximum(0.5 * (t3 / t0) - 0.5 * tau, 0.0)
        point = (((frames[f, 0, 0] + (t1 / t0) * frames[f, 1, 0]) + (t2 / t0) * frames[f, 2, 0])
                 - offset * n[0],
                 ((frames[f, 0, 1] + (t1 / t0) * frames[f, 1, 1]) + (t2 / t0) * frames[f, 2, 1])
                 - offset * n[1],
                 ((frames[f, 0, 2] + (t1 / t0) * frames[f, 1, 2]) + (t2 / t0) * frames[f, 2, 2])
                 - offset * n[2])
    else:  # the deepest incident vertex, moved half its depth back
        top_depth = maximum(top_p - tau, 0.0)
        point = (x_inc[top, 0] + 0.5 * top_depth * n[0], x_inc[top, 1] + 0.5 * top_depth * n[1],
                 x_inc[top, 2] + 0.5 * top_depth * n[2])
    region_depth = maximum(deepest - tau, 0.0)
    depth = sat_depth
    if found and region_depth < sat_depth - REGION_DEPTH_TOL_REL * scale:
        depth = region_depth
    if count == 0:  # nothing of the incident face reaches: the point alone
        manifold = work.manifold
        for c in range(3):
            manifold[0, c] = point[c]
        work.manifold_depth[0] = depth
        count = 1
    return point, depth, t0 if found else 0.0, feature, rank, count
