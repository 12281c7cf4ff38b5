"""Test helper: the exact distance between two convex polytopes as the minimum over their
vertex-face and edge-edge feature pairs (plain NumPy, slow: the tests' reference, never
served).

Not a test module. For disjoint convex polytopes the closest pair of points lies on a pair of
features; every pair's own closest distance bounds the distance from above, and the minimum is
reached by a vertex over a face's interior (the vertex's projection inside the face) or by two
edges (segments: their endpoints cover vertex-edge and vertex-vertex). Segment pairs use
Ericson's clamped closest points (*Real-Time Collision Detection* 5.1.9).

The closest region: every feature pair within :data:`SET_TOL_REL` x scale of the minimum, their
closest pairs' midpoints projected on the plane across the closest direction; their 2D hull is
the intersection of the two closest faces', edges' or vertices' shadows (its corners are the
vertices over faces and the edges' crossings), so its area centroid (a segment's midpoint, a
point) is the reference region centroid. ``spread``: how far those midpoints lie from the
minimising pair's (m); the closest points are unique where it is 0 (to rounding).

Computed in A's frame, returned in the world frame; poses are grouped in blocks so that one
block's arrays stay near a million entries.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from impactnet.models.compound.hull import Hull

#: Feature pairs within this (x pair scale, metres) of the minimum form the closest region:
#: above the rounding of the pairs' distances (a few 1e-16 of the coordinates), below any real
#: difference. A pair of features whose closest points lie d apart along a face differs in
#: distance by about d^2 / (2 gap), so the region is blurred by sqrt(2 gap x this) (1e-6 m at
#: a 0.5 m gap): the reference region centroid is good to that, the distance to rounding.
SET_TOL_REL = 1e-12
#: A vertex counts as over a face when its foot is inside every side of the face by -this
#: (x scale, m). 0: a foot on a side's line is also the edge pair's answer, and a foot outside
#: by d could undercut the distance by d x the dihedral's tangent.
INSIDE_TOL_REL = 0.0
#: Entries of one block's largest array.
BLOCK_ENTRIES = 1_000_000


@dataclass
class Reference:
    """The reference answer of N poses, world frame (module docstring)."""

    distance: np.ndarray  # (n,) m
    point_a: np.ndarray  # (n, 3) m: the minimising pair's point on A
    point_b: np.ndarray  # (n, 3) m: on B
    point: np.ndarray  # (n, 3) m: the closest region's centroid on the mid-plane
    direction: np.ndarray  # (n, 3) from A towards B (0 where they touch)
    spread: np.ndarray  # (n,) m: the closest region's reach from the minimising pair


@dataclass(frozen=True)
class _Features:
    """A hull's features in its body frame: corners (V, 3), edge ends (E, 2, 3), face normals
    (F, 3) and offsets (F,), face sides' inward normals (F, M, 3) and offsets (F, M); the faces
    in runs of equal side counts, ``groups`` ((start, stop, sides), ...), so that a vertex is
    tested against a face's own sides, not the widest face's padding."""

    vertices: np.ndarray
    edges: np.ndarray
    normals: np.ndarray
    offsets: np.ndarray
    side_normals: np.ndarray
    side_offsets: np.ndarray
    groups: tuple


def features(hull: Hull) -> _Features:
    """The features of ``hull``: its sides' inward normals are unit (a padded side's is zero:
    never binding)."""
    v = hull.vertices
    loops = hull.face_loops
    starts, ends = v[loops], v[np.roll(loops, -1, axis=1)]
    for f, count in enumerate(hull.face_counts):  # close each loop at its own corner count
        ends[f, count - 1] = v[loops[f, 0]]
        ends[f, count:] = starts[f, count:]
    sides = np.cross(hull.face_normals[:, None, :], ends - starts)
    length = np.linalg.norm(sides, axis=2, keepdims=True)
    sides = np.divide(sides, length, out=np.zeros_like(sides), where=length > 0.0)
    order = np.argsort(hull.face_counts, kind="stable")
    counts = np.asarray(hull.face_counts)[order]
    cuts = np.flatnonzero(np.diff(counts)) + 1
    groups = tuple((int(a), int(b), int(counts[a])) for a, b in
                   zip(np.r_[0, cuts], np.r_[cuts, len(counts)]))
    return _Features(v, v[hull.edges], hull.face_normals[order], hull.face_offsets[order],
                     sides[order], np.einsum("fmj,fmj->fm", sides, starts)[order], groups)


def _place(feat: _Features, t, r):
    """Features placed by P poses (``t`` (P, 3), ``r`` (P, 3, 3)): corners (P, V, 3), edges
    (P, E, 2, 3), face normals (P, F, 3) and offsets (P, F), sides (P, F, M, 3) and their
    offsets (P, F, M)."""
    def turned(x):  # x (..., 3) turned by every pose: (P, ..., 3), as batched products
        return (x.reshape(-1, 3) @ r.transpose(0, 2, 1)).reshape((len(r),) + x.shape)

    vertices = turned(feat.vertices) + t[:, None, :]
    edges = turned(feat.edges) + t[:, None, None, :]
    normals = turned(feat.normals)
    offsets = feat.offsets[None] + (normals @ t[:, :, None])[..., 0]
    sides = turned(feat.side_normals)
    side_offsets = feat.side_offsets[None] + (
        sides.reshape(len(r), -1, 3) @ t[:, :, None]).reshape(sides.shape[:3])
    return vertices, edges, normals, offsets, sides, side_offsets


def _vertex_face(x, faces, groups, tol):
    """Corners ``x`` (P, V, 3) over the other hull's faces (placed, their side-count
    ``groups``): distance (P, V*F) (inf where the corner is not over the face) and the foot on
    the face (P, V*F, 3)."""
    _, _, normals, offsets, sides, side_offsets = faces
    p = len(x)
    # Batched products (BLAS) rather than einsum: the same sums, minutes fewer in the slow suite.
    height = x @ normals.transpose(0, 2, 1) - offsets[:, None, :]
    inside = np.empty(height.shape, np.bool_)
    for start, stop, m in groups:
        across = x @ sides[:, start:stop, :m].reshape(p, -1, 3).transpose(0, 2, 1)
        inside[:, :, start:stop] = (across.reshape(p, len(x[0]), stop - start, m) -
                                    side_offsets[:, None, start:stop, :m] >= -tol).all(axis=3)
    foot = x[:, :, None, :] - height[..., None] * normals[:, None, :, :]
    distance = np.where(inside, np.abs(height), np.inf)
    return distance.reshape(p, -1), foot.reshape(p, -1, 3)


def segment_pairs(edges_a, edges_b):
    """Closest points of every segment of ``edges_a`` (P, Ea, 2, 3) to every one of
    ``edges_b`` (P, Eb, 2, 3): distance (P, Ea, Eb), point on A's and on B's (P, Ea, Eb, 3);
    Ericson 5.1.9, its dot products over pairs as batched products (their rounding, 1e-16 of
    the coordinates, is far below the tests' bounds)."""
    p1, p2 = edges_a[:, :, 0], edges_b[:, :, 0]
    d1, d2 = edges_a[:, :, 1] - p1, edges_b[:, :, 1] - p2
    a = (d1 * d1).sum(-1)[:, :, None]
    e = (d2 * d2).sum(-1)[:, None, :]
    b = d1 @ d2.transpose(0, 2, 1)
    c = (d1 * p1).sum(-1)[:, :, None] - d1 @ p2.transpose(0, 2, 1)  # d1 . (p1 - p2)
    f = p1 @ d2.transpose(0, 2, 1) - (d2 * p2).sum(-1)[:, None, :]  # d2 . (p1 - p2)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > 0.0, np.clip((b * f - c * e) / denom, 0.0, 1.0), 0.0)
        t = (b * s + f) / e
        s = np.where(t < 0.0, np.clip(-c / a, 0.0, 1.0),
                     np.where(t > 1.0, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    on_1 = p1[:, :, None] + s[..., None] * d1[:, :, None]
    on_2 = p2[:, None] + t[..., None] * d2[:, None]
    return np.linalg.norm(on_2 - on_1, axis=-1), on_1, on_2


def _candidates(fa, fb, t, r, scale):
    """Every feature pair's distance (P, K) and closest points on A and B (P, K, 3), A's
    frame."""
    p = len(t)
    a = _place(fa, np.zeros((p, 3)), np.broadcast_to(np.eye(3), (p, 3, 3)))
    b = _place(fb, t, r)
    tol = INSIDE_TOL_REL * scale
    d_vf, foot_b = _vertex_face(a[0], b, fb.groups, tol)
    d_fv, foot_a = _vertex_face(b[0], a, fa.groups, tol)
    d_ee, on_a, on_b = segment_pairs(a[1], b[1])
    count_f = {"a": a[2].shape[1], "b": b[2].shape[1]}
    corners_a = np.repeat(a[0], count_f["b"], axis=1)
    corners_b = np.repeat(b[0], count_f["a"], axis=1)
    distance = np.concatenate([d_vf, d_fv, d_ee.reshape(p, -1)], axis=1)
    on_a = np.concatenate([corners_a, foot_a, on_a.reshape(p, -1, 3)], axis=1)
    on_b = np.concatenate([foot_b, corners_b, on_b.reshape(p, -1, 3)], axis=1)
    return distance, on_a, on_b


def _region_centroid(mids, normal, fallback):
    """Area centroid (segment midpoint, point) of the hull of ``mids`` (k, 3) projected on
    the plane across ``normal``, at the mean height along it."""
    e1 = np.cross(normal, np.eye(3)[np.argmin(np.abs(normal))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    uv = (mids - fallback) @ np.stack([e1, e2], axis=1)
    height = float(((mids - fallback) @ normal).mean())
    try:
        hull = ConvexHull(uv)
        ring = uv[hull.vertices]
        cross = ring[:, 0] * np.roll(ring[:, 1], -1) - ring[:, 1] * np.roll(ring[:, 0], -1)
        centre = ((ring + np.roll(ring, -1, axis=0)) * cross[:, None]).sum(0) / (
            3.0 * cross.sum())
    except QhullError:  # collinear: a segment
        axis = uv[np.argmax(np.linalg.norm(uv - uv[0], axis=1))] - uv[0]
        along = uv @ axis
        centre = 0.5 * (uv[np.argmin(along)] + uv[np.argmax(along)])
    return fallback + centre[0] * e1 + centre[1] * e2 + height * normal


def _block(fa, fb, t, r, scale):
    """Reference rows (A's frame) of one block of poses."""
    distance, on_a, on_b = _candidates(fa, fb, t, r, scale)
    best = np.argmin(distance, axis=1)
    rows = np.arange(len(t))
    d = distance[rows, best]
    pa, pb = on_a[rows, best], on_b[rows, best]
    with np.errstate(divide="ignore", invalid="ignore"):
        direction = np.where(d[:, None] > 0.0, (pb - pa) / d[:, None], 0.0)
    point, spread = 0.5 * (pa + pb), np.zeros(len(t))
    for k in range(len(t)):
        near = distance[k] <= d[k] + SET_TOL_REL * scale
        mids = 0.5 * (on_a[k, near] + on_b[k, near])
        spread[k] = np.linalg.norm(mids - point[k], axis=1).max()
        if spread[k] > SET_TOL_REL * scale and d[k] > 0.0:
            point[k] = _region_centroid(mids, direction[k], point[k])
    return d, pa, pb, point, direction, spread


def reference_gaps(hull_a: Hull, hull_b: Hull, position_a, rotation_a, position_b,
                   rotation_b) -> Reference:
    """The reference at N poses (world frame; positions (n, 3) m, rotation matrices
    (n, 3, 3)) of two disjoint or touching hulls."""
    pa, ra = np.asarray(position_a, float), np.asarray(rotation_a, float)
    t = np.einsum("pji,pj->pi", ra, np.asarray(position_b, float) - pa)
    r = np.einsum("pji,pjk->pik", ra, np.asarray(rotation_b, float))
    fa, fb = features(hull_a), features(hull_b)
    scale = max(hull_a.half_extent, hull_b.half_extent)
    widest = max(len(fa.vertices) * fb.side_normals[:, :, 0].size,
                 len(fb.vertices) * fa.side_normals[:, :, 0].size,
                 len(fa.edges) * len(fb.edges))
    step = max(1, BLOCK_ENTRIES // widest)
    parts = [_block(fa, fb, t[i:i + step], r[i:i + step], scale)
             for i in range(0, len(t), step)]
    d, on_a, on_b, point, direction, spread = (np.concatenate(x) for x in zip(*parts))
    world = [np.einsum("pij,pj->pi", ra, x) + pa for x in (on_a, on_b, point)]
    return Reference(d, *world, np.einsum("pij,pj->pi", ra, direction), spread)
