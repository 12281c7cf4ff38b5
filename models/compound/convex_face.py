"""The face contact of two convex polyhedra: centre of pressure, depth, incident feature and
manifold, for m poses at once, in the reference body's frame (DESIGN.md's rule, as in
:mod:`impactnet.models.box.pressure`).

The reference face (outward normal ``n``, plane ``n . x = h``) belongs to the reference hull;
the other hull is incident, its vertices given in the reference hull's frame. Depth below the
reference plane is ``d = h - n . x``, the pressure ``p = d + tau`` with the box solver's floor
``tau`` (:data:`impactnet.models.box.pressure.PRESSURE_FLOOR_REL` of the pair's scale).

* Region: every fan triangle of every incident face that looks towards the reference face
  (``m . n < 0``), in the reference plane's coordinates (u, w), clipped to ``p >= 0`` and to
  the reference face's side planes (:mod:`impactnet.models.compound.polygon_clip`); all
  (pose, triangle) items that reach ``p >= 0`` at once.
* Point: the pressure-weighted mean of the mid-surface points ``y - n d / 2``; a pose whose
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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.box.tolerances import SNAP_TOL_REL
from impactnet.models.box.tolerances import PRESSURE_FLOOR_REL, REGION_DEPTH_TOL_REL
from impactnet.models.compound import polygon_clip as pc
from impactnet.models.compound.convex_sat import dot, rotate
from impactnet.models.compound.hull_stack import HullStack
from impactnet.models.contacts import MAX_MANIFOLD_POINTS

#: Incident hulls with more fan triangles than this have those beside the reference face
#: dropped before clipping (:func:`_beside_face_dropped`). Measured in one run on the bench's
#: twistlock poses: 21 % less time at 128 sides, 36 % at 256; with the few triangles of a box,
#: a ring piece or an 8-sided head (12-28) the test costs more (5-10 %) than it saves.
CULL_MIN_TRIANGLES = 64
#: Reference faces with more sides than this are clipped apart from the others
#: (:func:`_clip_to_face`): a box face has 4 sides, a ring piece's a few, a twistlock head's
#: sides 4 and its base and top 8-256.
FEW_SIDES = 8


@dataclass
class FaceRegion:
    """Face contacts of m poses, reference body's frame."""

    point: np.ndarray  # (m, 3) centre of pressure on the mid-surface (m)
    depth: np.ndarray  # (m,) penetration (m)
    pressure: np.ndarray  # (m,) int (d + tau) dA (m^3)
    feature: np.ndarray  # (m,) the incident hull's feature id
    rank: np.ndarray  # (m,) 1 vertex, 2 edge, 3 face
    manifold: np.ndarray  # (m, 8, 3) mid-surface points, zero padded
    manifold_depth: np.ndarray  # (m, 8)
    manifold_count: np.ndarray  # (m,)


def _plane_frames(ref: HullStack, rid: np.ndarray, face: np.ndarray):
    """Per pose: normal n (m, 3), offset h (m,), origin o (m, 3), in-plane axes e_u, e_w."""
    frames = ref.face_frames[rid, face]
    return (ref.face_normals[rid, face], ref.face_offsets[rid, face], frames[:, 0],
            frames[:, 1], frames[:, 2])


def _clip_to_face(ref: HullStack, rid, face, polygons, counts, item_row):
    """Polygons of items (k) clipped to ``p >= 0`` and their rows' reference faces' sides
    (:attr:`Hull.side_planes`, precomputed in each face's frame). Items whose face has more than
    :data:`FEW_SIDES` sides are clipped apart, so that a many-sided face (a twistlock head's
    base) does not make every other item of the batch pass its extra sides."""
    polygons, counts = pc.clip(polygons, counts, np.array([0.0, 0.0, 1.0, 0.0]), True)
    planes = ref.side_planes[rid[item_row], face[item_row]]  # (k, M, 4)
    sides = ref.face_counts[rid[item_row], face[item_row]]
    many = sides > FEW_SIDES
    if not many.any() or many.all():
        return _clip_sides(polygons, counts, planes, int(sides.max(initial=0)))
    parts = [(np.flatnonzero(group), *_clip_sides(polygons[group], counts[group],
                                                  planes[group], int(sides[group].max())))
             for group in (~many, many)]
    out = np.zeros((len(counts), max(p.shape[1] for _, p, _ in parts), 3))
    counts = counts.copy()
    for items, clipped, clipped_counts in parts:
        out[items, :clipped.shape[1]] = clipped
        counts[items] = clipped_counts
    return out, counts


def _clip_sides(polygons, counts, planes, sides: int):
    """``polygons`` clipped by the first ``sides`` side planes of ``planes`` (k, M, 4)."""
    for side in range(sides):
        if len(counts) == 0:
            break
        polygons, counts = pc.clip(polygons, counts, planes[:, side])
    return polygons, counts


def _beside_face_dropped(ref: HullStack, rid, face, row, polygons):
    """(row, polygons) without the triangles that lie wholly outside one side of their row's
    reference face: clipping would leave nothing of them (a many-sided twistlock head's base
    beside a ring piece's face), so the answer is the same, for less work."""
    planes = ref.side_planes[rid[row], face[row]]  # (k, M, 4)
    value = (polygons[:, :, pc.U, None] * planes[:, None, :, 0]
             + polygons[:, :, pc.W, None] * planes[:, None, :, 1] + planes[:, None, :, 3])
    keep = ~(value < 0.0).all(axis=1).any(axis=1)
    return row[keep], polygons[keep]


def _region(ref: HullStack, rid, face, frames, inc: HullStack, iid, rot_inc, uwp):
    """Moments (4, m) and the deepest pressure (m,) of the regions."""
    m = len(face)
    n = frames[0]
    front = dot(rotate(rot_inc, inc.face_normals[iid]), n[:, None]) < 0.0  # (m, F_inc)
    triangles = inc.triangles[iid]  # (m, T, 3)
    tri_p = np.take_along_axis(uwp[:, :, pc.P], triangles.reshape(m, -1), axis=1).reshape(
        triangles.shape)
    reach = (np.take_along_axis(front, inc.triangle_face[iid], axis=1)
             & (tri_p.max(axis=2) >= 0.0) & inc.triangle_valid[iid])
    row, tri = np.nonzero(reach)
    polygons = uwp[row[:, None], triangles[row, tri]]  # (k, 3, 3)
    if triangles.shape[1] > CULL_MIN_TRIANGLES:
        row, polygons = _beside_face_dropped(ref, rid, face, row, polygons)
    polygons, counts = _clip_to_face(ref, rid, face, polygons, np.full(len(row), 3), row)
    per_item = pc.moments(polygons, counts)
    totals = np.stack([np.bincount(row, per_item[i], minlength=m) for i in range(4)])
    slot = np.arange(polygons.shape[1])[None, :] < counts[:, None]
    reached = np.where(slot, polygons[:, :, pc.P], -np.inf).max(axis=1, initial=-np.inf)
    deepest = np.full(m, -np.inf)
    np.maximum.at(deepest, row, reached)
    return totals, deepest, front


def _incident_feature(inc: HullStack, iid, rot_inc, n, uwp, tau, scale):
    """(feature id, rank, incident face) per pose (module docstring)."""
    m = len(n)
    pressure = uwp[:, :, pc.P]
    deepest = np.argmax(pressure, axis=1)
    facing = dot(rotate(rot_inc, inc.face_normals[iid]), n[:, None])  # (m, F_inc)
    facing = np.where(inc.vertex_faces[iid, deepest], facing, np.inf)
    face = np.argmin(facing, axis=1)
    loops, counts = inc.face_loops[iid, face], inc.face_counts[iid, face]
    slot = np.arange(loops.shape[1])[None, :] < counts[:, None]
    depth = np.where(slot, np.take_along_axis(pressure, loops, axis=1) - tau[:, None], -np.inf)
    touching = (depth >= -(SNAP_TOL_REL * scale)[:, None]).sum(axis=1)
    order = np.argsort(-depth, axis=1, kind="stable")
    first = loops[np.arange(m), order[:, 0]]
    second = loops[np.arange(m), order[:, min(1, loops.shape[1] - 1)]]
    edge = inc.edge_of_vertices[iid, first, second]
    faces, edges = inc.n_faces[iid], inc.n_edges[iid]  # feature ids: faces, edges, vertices
    feature = np.where(touching >= 3, face,
                       np.where((touching == 2) & (edge >= 0), faces + edge,
                                faces + edges + first))
    rank = np.where(touching >= 3, 3, np.where((touching == 2) & (edge >= 0), 2, 1))
    return feature, rank, face


def _manifold(ref: HullStack, rid, face, frames, inc: HullStack, iid, inc_face, uwp, tau):
    """Mid-surface points (m, 8, 3), depths (m, 8) and counts (m,) of the clipped incident
    face."""
    m = len(face)
    n, _, origin, e_u, e_w = frames
    loops, counts = inc.face_loops[iid, inc_face], inc.face_counts[iid, inc_face]
    loops = loops[:, :max(int(counts.max(initial=0)), 1)]  # the loops' padding, trimmed
    polygons = np.take_along_axis(uwp, loops[:, :, None], axis=1)
    polygons, counts = _clip_to_face(ref, rid, face, polygons, counts, np.arange(m))
    width = polygons.shape[1]
    pick = (np.arange(MAX_MANIFOLD_POINTS)[None, :] * np.maximum(counts, 1)[:, None]
            // MAX_MANIFOLD_POINTS)
    pick = np.where(counts[:, None] > MAX_MANIFOLD_POINTS, pick,
                    np.minimum(np.arange(MAX_MANIFOLD_POINTS)[None, :], width - 1))
    chosen = np.take_along_axis(polygons, pick[:, :, None], axis=1)
    count = np.minimum(counts, MAX_MANIFOLD_POINTS)
    valid = np.arange(MAX_MANIFOLD_POINTS)[None, :] < count[:, None]
    depth = np.where(valid, np.maximum(chosen[:, :, pc.P] - tau[:, None], 0.0), 0.0)
    points = (origin[:, None] + chosen[:, :, pc.U, None] * e_u[:, None]
              + chosen[:, :, pc.W, None] * e_w[:, None] - 0.5 * depth[:, :, None] * n[:, None])
    return np.where(valid[:, :, None], points, 0.0), depth, count


def face_region(ref: HullStack, rid: np.ndarray, face: np.ndarray, inc: HullStack,
                iid: np.ndarray, x_inc: np.ndarray, rot_inc: np.ndarray, sat_depth: np.ndarray,
                scale: np.ndarray) -> FaceRegion:
    """The face contacts of m poses (module docstring), in the reference hull's frame.

    Parameters
    ----------
    ref : HullStack
        The hulls of the reference faces; ``rid`` (m,) each row's.
    face : ndarray of int, shape (m,)
        The reference face of each pose.
    inc : HullStack
        The incident hulls; ``iid`` (m,) each row's.
    x_inc : ndarray, shape (m, V_inc, 3)
        The incident hull's vertices in the reference frame (metres).
    rot_inc : ndarray, shape (m, 3, 3)
        The rotation from the incident hull's frame to the reference frame.
    sat_depth : ndarray, shape (m,)
        The separating-axis overlap along the reference normal (metres).
    scale : ndarray, shape (m,)
        The pair's scale (metres).
    """
    tau = PRESSURE_FLOOR_REL * scale
    frames = _plane_frames(ref, rid, face)
    n, h, origin, e_u, e_w = frames
    rel = x_inc - origin[:, None]
    uwp = np.stack([dot(rel, e_u[:, None]), dot(rel, e_w[:, None]),
                    h[:, None] - dot(x_inc, n[:, None]) + tau[:, None]], axis=2)
    totals, deepest, _ = _region(ref, rid, face, frames, inc, iid, rot_inc, uwp)
    found = totals[0] > 0.0
    safe = np.where(found, totals[0], 1.0)
    offset = np.maximum(0.5 * (totals[3] / safe) - 0.5 * tau, 0.0)
    point = (origin + (totals[1] / safe)[:, None] * e_u + (totals[2] / safe)[:, None] * e_w
             - offset[:, None] * n)
    top = np.argmax(uwp[:, :, pc.P], axis=1)
    top_depth = np.maximum(uwp[np.arange(len(face)), top, pc.P] - tau, 0.0)
    fallback = x_inc[np.arange(len(face)), top] + 0.5 * top_depth[:, None] * n
    region_depth = np.maximum(deepest - tau, 0.0)
    shallower = found & (region_depth < sat_depth - REGION_DEPTH_TOL_REL * scale)
    feature, rank, inc_face = _incident_feature(inc, iid, rot_inc, n, uwp, tau, scale)
    manifold, manifold_depth, count = _manifold(ref, rid, face, frames, inc, iid, inc_face, uwp,
                                                tau)
    point = np.where(found[:, None], point, fallback)
    depth = np.where(shallower, region_depth, sat_depth)
    empty = count == 0  # nothing of the incident face reaches: the point alone
    manifold[empty, 0], manifold_depth[empty, 0] = point[empty], depth[empty]
    return FaceRegion(point, depth, np.where(found, totals[0], 0.0), feature, rank, manifold,
                      manifold_depth, np.maximum(count, 1))
