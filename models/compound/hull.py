"""Convex hulls of parts as the convex solver needs them: faces, edges, vertices and the tables
that tie them together, with stable feature ids (issue #20, step 2).

A :class:`Hull` is built once per part definition (:func:`hull_of`, cached) in its body's frame:

* vertices (V, 3), the hull's corners (interior and coplanar input points dropped), in the
  order of the input points;
* faces: the hull's planar facets (coplanar triangles of Qhull merged), each with its outward
  unit normal, its plane offset ``h`` (``n . x <= h`` inside) and its vertex loop,
  counter-clockwise seen from outside;
* edges: the facets' boundary segments, each joining two vertices and separating two faces;
* ``triangles``: a fan triangulation of every face (for the integrals of the face solver).

Feature ids, one integer space as for boxes (:mod:`impactnet.models.geometry.box_features`):
faces ``0 .. F-1``, edges ``F .. F+E-1``, vertices ``F+E .. F+E+V-1``. They are stable for a
given part definition: the hull of the same points is the same tables in the same order. A box
part's hull (:func:`box_hull`) uses exactly the box's ids (faces 0-5, edges 6-17, vertices
18-25), so a box part answers with the same features through either solver.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from impactnet.models.compound.parts import BoxPart, ConvexPart, Part, PartError
from impactnet.models.geometry import box_features as bf

#: Two hull triangles lie in one face when their unit normals differ by less than this
#: (|n1 - n2|, dimensionless) and their plane offsets by less than it times the part's size:
#: far above the rounding of generated points (1e-16), far below the 0.025 rad between two
#: adjacent sides of a 256-sided stadium's caps and any real chamfer.
COPLANAR_TOL = 1e-9


@dataclass(frozen=True)
class Hull:
    """A convex polyhedron's tables, body frame, metres (module docstring)."""

    vertices: np.ndarray  # (V, 3) corners
    face_normals: np.ndarray  # (F, 3) outward unit normals
    face_offsets: np.ndarray  # (F,) n . x of the face's plane (m)
    face_loops: np.ndarray  # (F, M) vertex indices, CCW from outside, padded by repeating
    face_counts: np.ndarray  # (F,) vertices per face
    edges: np.ndarray  # (E, 2) vertex indices of each edge
    edge_faces: np.ndarray  # (E, 2) the two faces that meet at each edge
    edge_of_vertices: np.ndarray  # (V, V) edge index joining two vertices, -1 if none
    triangles: np.ndarray  # (T, 3) vertex indices: fan triangles of the faces
    triangle_face: np.ndarray  # (T,) the face of each triangle
    vertex_faces: np.ndarray  # (V, F) bool: the vertex lies on the face
    half_extent: float  # the largest half-extent of the hull's bounding box (m)
    face_frames: np.ndarray  # (F, 3, 3) per face: origin (its first vertex), in-plane axes u, w
    side_planes: np.ndarray  # (F, M, 4) per face side: c . (u, w, p, 1) >= 0 inside (metres);
    # (0, 0, 0, 1) past the face's sides

    @property
    def n_faces(self) -> int:
        return len(self.face_normals)

    @property
    def n_edges(self) -> int:
        return len(self.edges)

    def edge_id(self, edge):
        """Feature ids of edge indices (any shape)."""
        return self.n_faces + np.asarray(edge)

    def vertex_id(self, vertex):
        """Feature ids of vertex indices (any shape)."""
        return self.n_faces + self.n_edges + np.asarray(vertex)

    def inside_planes(self) -> tuple[np.ndarray, np.ndarray]:
        """(normals (F, 3), offsets (F,)): a point x is inside iff ``normals @ x <= offsets``."""
        return self.face_normals, self.face_offsets


def _loop_tables(loops: list[list[int]], n_vertices: int):
    """Padded loops, counts, edges, their faces, the vertex-pair table and fan triangles."""
    width = max(len(loop) for loop in loops)
    padded = np.array([loop + [loop[-1]] * (width - len(loop)) for loop in loops], np.int64)
    counts = np.array([len(loop) for loop in loops], np.int64)
    edge_of = np.full((n_vertices, n_vertices), -1, np.int64)
    edges, faces_of_edge = [], []
    for f, loop in enumerate(loops):
        for a, b in zip(loop, loop[1:] + loop[:1]):
            e = edge_of[a, b]
            if e < 0:
                e = len(edges)
                edge_of[a, b] = edge_of[b, a] = e
                edges.append((min(a, b), max(a, b)))
                faces_of_edge.append([f, -1])
            else:
                faces_of_edge[e][1] = f
    triangles = [(loop[0], loop[i], loop[i + 1]) for loop in loops for i in range(1, len(loop) - 1)]
    triangle_face = [f for f, loop in enumerate(loops) for _ in range(len(loop) - 2)]
    return (padded, counts, np.array(edges, np.int64), np.array(faces_of_edge, np.int64),
            edge_of, np.array(triangles, np.int64), np.array(triangle_face, np.int64))


def _make(vertices, normals, offsets, loops) -> Hull:
    padded, counts, edges, edge_faces, edge_of, tris, tri_face = _loop_tables(loops,
                                                                             len(vertices))
    if (edge_faces < 0).any():
        raise ValueError("the face loops do not close: an edge has only one face")
    for array in (vertices, normals, offsets, padded, counts, edges, edge_faces, edge_of, tris,
                  tri_face):
        array.setflags(write=False)
    vertex_faces = np.zeros((len(vertices), len(loops)), bool)
    for f, loop in enumerate(loops):
        vertex_faces[loop, f] = True
    vertex_faces.setflags(write=False)
    extent = 0.5 * float((vertices.max(axis=0) - vertices.min(axis=0)).max())
    frames, sides = _face_planes(vertices, normals, padded, counts)
    return Hull(vertices, normals, offsets, padded, counts, edges, edge_faces, edge_of, tris,
                tri_face, vertex_faces, extent, frames, sides)


def _face_planes(vertices, normals, loops, counts):
    """Each face's frame (origin, u, w) and its sides as half-planes in (u, w) (module
    docstring of :mod:`impactnet.models.compound.convex_face`)."""
    origin = vertices[loops[:, 0]]
    e_u = vertices[loops[:, 1]] - origin
    e_u /= np.linalg.norm(e_u, axis=1, keepdims=True)
    e_w = np.cross(normals, e_u)
    frames = np.stack([origin, e_u, e_w], axis=1)
    width = loops.shape[1]
    sides = np.tile(np.array([0.0, 0.0, 0.0, 1.0]), (len(loops), width, 1))
    for f in range(len(loops)):
        rel = vertices[loops[f, :counts[f]]] - origin[f]
        uv = np.stack([rel @ e_u[f], rel @ e_w[f]], axis=1)
        edge = np.roll(uv, -1, axis=0) - uv
        length = np.linalg.norm(edge, axis=1)
        sides[f, :counts[f]] = np.stack([-edge[:, 1], edge[:, 0], np.zeros(counts[f]),
                                         edge[:, 1] * uv[:, 0] - edge[:, 0] * uv[:, 1]],
                                        axis=1) / length[:, None]
    frames.setflags(write=False)
    sides.setflags(write=False)
    return frames, sides


def box_hull(size, centre=(0.0, 0.0, 0.0)) -> Hull:
    """The hull of a box of full edges ``size`` (3,) at ``centre`` (3,), metres, with the
    box's own feature ids (:mod:`impactnet.models.geometry.box_features`)."""
    vertices = bf.vertex_positions(np.asarray(size, np.float64)) + np.asarray(centre, float)
    normals = bf.face_normals()
    offsets = (normals * (bf.face_centers(np.asarray(size, float)) + centre)).sum(axis=1)
    loops = (bf.FACE_VERTICES - bf.VERTEX_BASE).tolist()
    hull = _make(vertices, normals, offsets, loops)
    ids = hull.edge_id(hull.edge_of_vertices[bf.EDGE_VERTICES[:, 0] - bf.VERTEX_BASE,
                                             bf.EDGE_VERTICES[:, 1] - bf.VERTEX_BASE])
    if not np.array_equal(ids, np.arange(bf.EDGE_BASE, bf.VERTEX_BASE)):
        return _reorder_box_edges(hull)
    return hull


def _reorder_box_edges(hull: Hull) -> Hull:
    """The box hull with its edges renumbered to the box's edge ids."""
    ends = bf.EDGE_VERTICES - bf.VERTEX_BASE  # (12, 2)
    edges = np.sort(ends, axis=1)
    edge_of = np.full_like(hull.edge_of_vertices, -1)
    edge_of[edges[:, 0], edges[:, 1]] = edge_of[edges[:, 1], edges[:, 0]] = np.arange(12)
    old = hull.edge_of_vertices[edges[:, 0], edges[:, 1]]
    edge_faces = hull.edge_faces[old]
    for array in (edges, edge_of, edge_faces):
        array.setflags(write=False)
    return Hull(hull.vertices, hull.face_normals, hull.face_offsets, hull.face_loops,
                hull.face_counts, edges, edge_faces, edge_of, hull.triangles,
                hull.triangle_face, hull.vertex_faces, hull.half_extent, hull.face_frames,
                hull.side_planes)


def _merged_faces(points: np.ndarray, name: str):
    """Qhull's triangles merged into planar faces: (normals, offsets, loops), in the order of
    each face's first triangle; vertex indices into ``points``."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        qhull = ConvexHull(points)
    except QhullError as exc:
        raise PartError(name, f"no convex hull: {str(exc).splitlines()[0]}") from None
    size = float(np.ptp(points, axis=0).max())
    normals, offsets = qhull.equations[:, :3], -qhull.equations[:, 3]
    group = np.full(len(normals), -1)
    faces = []
    for start in range(len(normals)):
        if group[start] >= 0:
            continue
        group[start] = len(faces)
        members, stack = [start], [start]
        while stack:  # flood over neighbours in the same plane
            for other in qhull.neighbors[stack.pop()]:
                if group[other] < 0 and _coplanar(normals, offsets, start, other, size):
                    group[other] = len(faces)
                    members.append(other)
                    stack.append(other)
        faces.append(members)
    loops = [_ordered_loop(points, qhull.simplices[m], normals[m[0]]) for m in faces]
    return (np.array([normals[m[0]] for m in faces]), np.array([offsets[m[0]] for m in faces]),
            loops)


def _coplanar(normals, offsets, i, j, size) -> bool:
    return (np.abs(normals[i] - normals[j]).max() < COPLANAR_TOL
            and abs(offsets[i] - offsets[j]) < COPLANAR_TOL * size)


def _ordered_loop(points, simplices, normal) -> list[int]:
    """The face's vertices, counter-clockwise about ``normal`` (seen from outside), starting
    at the lowest index; points on the face's edges but not corners are dropped."""
    index = np.unique(simplices)
    centre = points[index].mean(axis=0)
    u = points[index[0]] - centre
    u /= np.linalg.norm(u)
    w = np.cross(normal, u)
    rel = points[index] - centre
    order = index[np.argsort(np.arctan2(rel @ w, rel @ u))]
    keep = []
    for k, v in enumerate(order):  # drop corners that are not corners (collinear)
        prev, nxt = points[order[k - 1]], points[order[(k + 1) % len(order)]]
        turn = np.cross(points[v] - prev, nxt - points[v]) @ normal
        if turn > COPLANAR_TOL * np.linalg.norm(points[v] - prev) * np.linalg.norm(nxt - prev):
            keep.append(int(v))
    start = int(np.argmin(keep))
    return keep[start:] + keep[:start]


def convex_hull(points, name: str = "part") -> Hull:
    """The :class:`Hull` of ``points`` (k, 3), metres (body frame)."""
    points = np.asarray(points, np.float64)
    normals, offsets, loops = _merged_faces(points, name)
    used = np.unique(np.concatenate([np.asarray(loop) for loop in loops]))
    renumber = np.full(len(points), -1)
    renumber[used] = np.arange(len(used))
    loops = [renumber[loop].tolist() for loop in loops]
    return _make(points[used].copy(), normals, offsets, loops)


def build_hull(part: Part) -> Hull:
    """The hull of a part: :func:`box_hull` for a box, :func:`convex_hull` else."""
    if isinstance(part, BoxPart):
        return box_hull(part.size, part.centre)
    if isinstance(part, ConvexPart):
        return convex_hull(part.vertices(), part.name)
    raise TypeError(f"not a part: {part!r}")


#: The cached hull of a part (hulls of a scene's parts; a request's own parts use
#: :func:`build_hull`, outside the cache).
hull_of = lru_cache(maxsize=512)(build_hull)
