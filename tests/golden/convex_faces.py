"""Margins of a convex face contact's decisions (not a test module).

For the face-axis poses of :func:`tests.golden.convex_decide.convex_decide`, in the reference
hull's frame, following :mod:`impactnet.models.compound.convex_face`:

* feature: the incident face (of the faces at the deepest vertex, the most anti-parallel: the
  gap to the next; 0 where another vertex within the tolerance of the deepest would pick
  another face) and its touching vertices (``|depth + snap tol|``);
* clip: the incident face clipped to ``p >= 0`` and the reference face's side planes (the
  manifold): the smallest |plane value| of any polygon vertex met on the way;
* region: the deepest point of the incident hull inside the reference face's prism, against
  ``SAT depth - REGION_DEPTH_TOL_REL x scale`` and against ``-tau`` (an empty region).

Lengths in metres; own code (see :mod:`tests.golden.box_axes`).
"""
from __future__ import annotations

import numpy as np

from tests.golden import rule


def clip_margin(polygon: np.ndarray, planes: np.ndarray) -> float:
    """Smallest |value| of a polygon's vertices against each half-plane ``c . (u, w, p, 1) >=
    0`` met while clipping it by them in turn (Sutherland-Hodgman); ``polygon`` (k, 3)."""
    smallest = np.inf
    for plane in planes:
        if len(polygon) == 0:
            break
        value = polygon @ plane[:3] + plane[3]
        smallest = min(smallest, float(np.abs(value).min()))
        inside = value >= 0.0
        out = []
        for i in range(len(polygon)):
            j = (i + 1) % len(polygon)
            if inside[i]:
                out.append(polygon[i])
            if inside[i] != inside[j]:
                lam = value[i] / (value[i] - value[j])
                out.append(polygon[i] + lam * (polygon[j] - polygon[i]))
        polygon = np.array(out).reshape(-1, 3)
    return smallest


def _incident_face(inc, facing, p, tol):
    """One pose: (incident face, its choice's margin, dimensionless) from the faces' cosines
    with the normal ``facing`` (F,) and the vertices' depths ``p`` (V,)."""
    def pick(vertex):
        masked = np.where(inc.vertex_faces[vertex], facing, np.inf)
        return int(masked.argmin()), np.sort(masked)

    deepest = int(p.argmax())
    face, ranked = pick(deepest)
    gap = ranked[1] - ranked[0] if np.isfinite(ranked[1]) else np.inf
    for vertex in np.flatnonzero(p >= p[deepest] - tol):
        if pick(vertex)[0] != face:
            return face, 0.0
    return face, gap


def _region_depth(inc, x_inc, planes_inc, frame, sides, corners, h):
    """Deepest depth (m,) of the incident hull in the reference face's prism, -inf if none:
    hull vertices inside, hull edges through a side plane, the prism's corner lines."""
    n, origin, e_u, e_w = frame
    rel = x_inc - origin
    uw1 = np.stack([rel @ e_u, rel @ e_w, np.zeros(len(rel)), np.ones(len(rel))], axis=1)
    value = uw1 @ sides.T  # (V, S)
    depth = h - x_inc @ n
    best = np.where((value >= 0.0).all(axis=1), depth, -np.inf).max(initial=-np.inf)
    v0, v1 = inc.edges[:, 0], inc.edges[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = value[v0] / (value[v0] - value[v1])  # (E, S)
    cut = (value[v0] < 0.0) != (value[v1] < 0.0)
    for s in range(sides.shape[0]):
        at = np.flatnonzero(cut[:, s])
        point = x_inc[v0[at]] + lam[at, s, None] * (x_inc[v1[at]] - x_inc[v0[at]])
        pv = np.stack([(point - origin) @ e_u, (point - origin) @ e_w, np.zeros(len(at)),
                       np.ones(len(at))], axis=1) @ sides.T
        pv[:, s] = 0.0
        ok = (pv >= -1e-15 * np.abs(point).max(initial=1.0)).all(axis=1)
        best = max(best, (h - point[ok] @ n).max(initial=-np.inf))
    normals, offsets = planes_inc
    for corner in corners:
        base = origin + corner[0] * e_u + corner[1] * e_w
        slope, room = -(normals @ n), offsets - normals @ base  # slope s <= room, s along -n
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = room / slope
        lo = np.where(slope < 0.0, bound, -np.inf).max(initial=-np.inf)
        hi = np.where(slope > 0.0, bound, np.inf).min(initial=np.inf)
        if lo <= hi and not ((slope == 0.0) & (room < 0.0)).any():
            best = max(best, h - (base - hi * n) @ n)
    return best


def convex_face_margins(ref, face, inc, x_inc, rot_inc, planes_inc, sat_depth, scale, tol):
    """Margins (each (m,)) of m face contacts: feature_unit, feature_depth, clip, region,
    empty, and the incident rank (1 vertex, 2 edge, 3 face) and face.

    ``ref``, ``inc``: the reference and incident hulls; ``face`` (m,) the reference face;
    ``x_inc`` (m, V, 3) the incident vertices and ``rot_inc`` (m, 3, 3) the incident frame in
    the reference hull's frame; ``planes_inc`` a list of m (normals (F, 3), offsets (F,)) of
    the incident hull there; ``tol`` (m,) the borderline length (metres).
    """
    m = len(face)
    n, h = ref.face_normals[face], ref.face_offsets[face]
    frames = ref.face_frames[face]
    origin, e_u, e_w = frames[:, 0], frames[:, 1], frames[:, 2]
    tau = rule.PRESSURE_FLOOR_REL * scale
    snap = rule.SNAP_TOL_REL * scale
    rel = x_inc - origin[:, None]
    u, w = np.einsum("mvi,mi->mv", rel, e_u), np.einsum("mvi,mi->mv", rel, e_w)
    depth = h[:, None] - np.einsum("mvi,mi->mv", x_inc, n)
    facing = np.einsum("mij,fj,mi->mf", rot_inc, inc.face_normals, n)  # (m, F_inc)
    out = {name: np.full(m, np.inf) for name in ("feature_depth", "clip", "region", "empty",
                                                 "feature_unit")}
    inc_face, out["rank"] = np.zeros(m, int), np.ones(m, int)
    for r in range(m):
        inc_face[r], out["feature_unit"][r] = _incident_face(inc, facing[r], depth[r], tol[r])
        loop = inc.face_loops[inc_face[r], :inc.face_counts[inc_face[r]]]
        touching = depth[r, loop] >= -snap[r]
        out["feature_depth"][r] = np.abs(depth[r, loop] + snap[r]).min()
        order = np.argsort(-depth[r, loop], kind="stable")
        edge = inc.edge_of_vertices[loop[order[0]], loop[order[min(1, len(loop) - 1)]]]
        count = int(touching.sum())
        out["rank"][r] = 3 if count >= 3 else (2 if count == 2 and edge >= 0 else 1)
        count_f = ref.face_counts[face[r]]
        sides = ref.side_planes[face[r], :count_f]
        polygon = np.stack([u[r, loop], w[r, loop], depth[r, loop] + tau[r]], axis=1)
        planes = np.concatenate([[[0.0, 0.0, 1.0, 0.0]], sides])
        out["clip"][r] = clip_margin(polygon, planes)
        corners = np.array([[np.dot(ref.vertices[v] - origin[r], e_u[r]),
                             np.dot(ref.vertices[v] - origin[r], e_w[r])]
                            for v in ref.face_loops[face[r], :count_f]])
        deepest = _region_depth(inc, x_inc[r], planes_inc[r], (n[r], origin[r], e_u[r], e_w[r]),
                                sides, corners, h[r])
        out["empty"][r] = abs(deepest + tau[r])
        if deepest >= -tau[r]:
            out["region"][r] = abs(max(deepest, 0.0) - sat_depth[r]
                                   + rule.REGION_DEPTH_TOL_REL * scale[r])
    out["face"] = inc_face
    return out
