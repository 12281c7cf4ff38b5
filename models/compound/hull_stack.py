"""Several hulls as one set of flat tables (CSR style), so that the compiled convex solver
answers rows of different part pairs in one call: the compound oracle's narrowphase, and a
single pose's handful of part pairs.

A :class:`HullTable` holds H hulls (:class:`impactnet.models.compound.hull.Hull`) back to back,
each hull's entries at its own offsets; a row of the solver names its hull by an index into the
table. Nothing is padded: a box part's rows read 8 vertices, 6 faces and 12 edges whatever other
hulls share its table. The arrays, for the kernels (:class:`HullArrays`, read-only):

* per hull: offsets of its vertices, faces, edges and Gauss-map tree nodes (``*_start``,
  H + 1), the mean of its vertices (``centre``), its largest half-extent, its reach (the
  largest ``|x| + |y| + |z|`` of a vertex, metres: the magnitude the searches' rounding scales
  with), its radius about ``centre``, its longest edge, its flatness (how far a vertex lies
  outside a face plane or a face's loop off its plane, metres), whether it is convex to
  :data:`CLIMB_FLAT_TOL_REL` of its reach (``convex``: the separating-axis test may bound
  and climb on it), whether its support searches climb (``climb``: convex and at least
  :data:`CLIMB_MIN_VERTICES` vertices) and the sine of its shortest Gauss-map arc;
* per vertex: position (body frame), its neighbours and the edges to them (``adjacency_*``,
  CSR), the faces that hold it (``vertex_face*``, CSR, ascending);
* per face: outward unit normal, plane offset, frame (origin, in-plane u, w), its vertex loop
  (``loop_*``, CSR, counter-clockwise from outside) with one side plane per loop entry, and
  an order of the faces along a spanning tree of nearest normals (``face_order``,
  ``face_parent``: a face's support search starts where its parent's ended);
* per edge: its two vertices and two faces (as :class:`Hull` has them), its Gauss-map arc's
  normal ``n1 x n0`` (``edge_arcs``), the arc's angle ``theta`` as ``cos``, ``sin``,
  ``tan(theta / 2)`` and ``theta / sin(theta)`` (``edge_angle``) and its unit direction
  (``edge_dir``);
* the Gauss-map tree: a binary tree over the edges' Gauss-map arcs (great-circle arcs between
  the two faces' normals), each node a spherical cap that contains its arcs and a cone that
  contains its edges' directions (as lines, ``node_dir``, ``node_cone_*``), leaves of at most
  :data:`LEAF_ARCS` arcs whose directions lie within :data:`LEAF_CONE_RAD` of each other;
  each node's edges listed from ``node_first`` in ``tree_edge`` (a subtree's edges are
  contiguous). The separating-axis test visits only the pairs of nodes whose caps meet and
  whose edges may separate the hulls more than every face
  (:mod:`impactnet.models.compound.convex_sat`).

Vertex, face, edge and node indices inside the tables are each hull's own (add the hull's
``*_start`` for a position in the arrays); CSR starts (``adjacency_start``, ``vertex_face_start``,
``loop_start``, ``node_first``) are positions in the arrays. Feature ids stay each hull's own.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from impactnet.models.compound.hull import Hull

#: Tables kept (keyed by the hulls' identities; a scene's bodies need a few).
CACHED_STACKS = 256
#: Arcs per leaf of the Gauss-map tree. Measured (one thread, us per pair, 256-sided heads on
#: each other at random / resting, and on a plate): 2 arcs 139/674/52, 4 130/622/49, 8
#: 128/606/48, 16 128/635/48.
LEAF_ARCS = 8
#: A leaf's edge directions (as lines) lie within this of its cone's axis (radians): a box's
#: leaves hold parallel edges only, a head's a few neighbours (the edge-axis search drops a
#: pair of nodes by its bound only where their cones are apart or the bound is far enough).
LEAF_CONE_RAD = 0.2
#: Every cap of the Gauss-map tree is widened by this (radians), far above the rounding of a
#: unit vector (1e-16), so that two arcs the solver's exact crossing test calls crossing always
#: lie in caps that meet.
CAP_MARGIN_RAD = 1e-6
#: Support searches climb over the vertex graph of hulls with at least this many vertices (a
#: box's 8 included). Measured (one thread, us per pair of heads of 8 / 32 / 128 sides on each
#: other): climbing from 8 vertices 4.9 / 15 / 60, from 64 5.3 / 15 / 59, never 5.4 / 19 / 125.
CLIMB_MIN_VERTICES = 8
#: A hull whose vertices lie off its own face planes by more than this (x its reach, metres)
#: is not convex enough to climb on (a client's mesh merged at the hull's COPLANAR_TOL): its
#: supports are found by scanning every vertex.
CLIMB_FLAT_TOL_REL = 1e-13


class HullArrays(NamedTuple):
    """The flat tables of H hulls (module docstring), read-only, for the kernels."""

    vertex_start: np.ndarray  # (H + 1,) int64
    face_start: np.ndarray  # (H + 1,) int64
    edge_start: np.ndarray  # (H + 1,) int64
    node_start: np.ndarray  # (H + 1,) int64
    centre: np.ndarray  # (H, 3) mean of each hull's vertices (m)
    half_extent: np.ndarray  # (H,) largest half-extent of each hull's bounds (m)
    reach: np.ndarray  # (H,) largest |x| + |y| + |z| of a vertex (m)
    radius: np.ndarray  # (H,) largest distance of a vertex from centre (m)
    flat: np.ndarray  # (H,) flatness (m): vertices outside face planes, loops off them
    convex: np.ndarray  # (H,) bool: flat <= CLIMB_FLAT_TOL_REL x reach
    climb: np.ndarray  # (H,) bool: supports by climbing the vertex graph
    arc_min_sin: np.ndarray  # (H,) sine of the shortest Gauss-map arc
    longest_edge: np.ndarray  # (H,) the longest edge (m)
    vertices: np.ndarray  # (V, 3) body frame (m)
    adjacency_start: np.ndarray  # (V + 1,) int64
    adjacency_vertex: np.ndarray  # (2E,) int64 neighbouring vertex
    adjacency_edge: np.ndarray  # (2E,) int64 the edge to it
    vertex_face_start: np.ndarray  # (V + 1,) int64
    vertex_face: np.ndarray  # (L,) int64 faces holding each vertex, ascending
    face_normals: np.ndarray  # (F, 3) outward unit normals
    face_offsets: np.ndarray  # (F,) n . x of each face's plane (m)
    face_frames: np.ndarray  # (F, 3, 3) origin, in-plane axes u, w
    loop_start: np.ndarray  # (F + 1,) int64
    loop_vertex: np.ndarray  # (L,) int64 each face's vertices, CCW from outside
    side_planes: np.ndarray  # (L, 4) each face's sides in its frame (Hull.side_planes)
    face_order: np.ndarray  # (F,) int64 faces along a spanning tree from face 0
    face_parent: np.ndarray  # (F,) int64 each face's parent in the tree (-1: face 0)
    edges: np.ndarray  # (E, 2) int64 vertex indices
    edge_faces: np.ndarray  # (E, 2) int64 the two faces at each edge
    edge_arcs: np.ndarray  # (E, 3) n1 x n0 of the two faces' normals
    edge_angle: np.ndarray  # (E, 4) cos, sin, tan(theta / 2), theta / sin(theta) of the arc
    edge_dir: np.ndarray  # (E, 3) unit direction, from its first vertex to its second
    node_centre: np.ndarray  # (N, 3) unit centre of each cap
    node_radius: np.ndarray  # (N,) angular radius (rad), margin included
    node_cos: np.ndarray  # (N,) cos of the radius
    node_sin: np.ndarray  # (N,) sin of the radius
    node_left: np.ndarray  # (N,) int64 children (hull's own node indices), -1 for a leaf
    node_right: np.ndarray  # (N,) int64
    node_first: np.ndarray  # (N,) int64 the node's first position in tree_edge
    node_count: np.ndarray  # (N,) int64 the node's arcs (its subtree's, listed from there)
    node_dir: np.ndarray  # (N, 3) unit axis of the cone of the node's edge directions
    node_cone_cos: np.ndarray  # (N,) cos of the cone's half-angle (lines: +-direction)
    node_cone_sin: np.ndarray  # (N,) sin of it
    tree_edge: np.ndarray  # (E,) int64 edges, leaf by leaf


@dataclass(frozen=True, eq=False)
class HullTable:
    """H hulls as flat tables (module docstring); body frames, metres."""

    hulls: tuple[Hull, ...]  # the hulls themselves (their identities key the cache)
    arrays: HullArrays  # the tables, for the kernels
    n_faces: np.ndarray  # (H,) each hull's face count (feature ids)
    n_edges: np.ndarray  # (H,) each hull's edge count (feature ids)
    widest: dict  # the largest per-hull counts: "V", "F", "E", "L" (loop), "N" (tree nodes)

    @property
    def width(self) -> dict[str, int]:
        """The largest per-hull counts (the solver's scratch is sized by them)."""
        return self.widest


def _arc_tree(normals: np.ndarray, edge_faces: np.ndarray, directions: np.ndarray):
    """The Gauss-map tree of one hull: nodes (centre, radius, left, right, first, count,
    direction axis, direction half-angle) and the edges leaf by leaf. Caps are split at the
    median of their arcs' midpoints along the axis of widest spread."""
    a, b = normals[edge_faces[:, 0]], normals[edge_faces[:, 1]]
    middle = a + b  # a convex hull's dihedral angles are below pi: never zero
    middle /= np.linalg.norm(middle, axis=1, keepdims=True)
    half = 0.5 * np.arccos(np.clip((a * b).sum(axis=1), -1.0, 1.0))
    nodes: list = []
    order: list[int] = []

    def cone(members: np.ndarray) -> tuple[np.ndarray, float]:
        lines = directions[members]
        axis = np.linalg.eigh(lines.T @ lines)[1][:, -1]  # the principal direction
        angle = np.arccos(np.clip(np.abs(lines @ axis), 0.0, 1.0)).max() + CAP_MARGIN_RAD
        return axis, float(min(angle, 0.5 * np.pi))

    def build(members: np.ndarray) -> int:
        node = len(nodes)
        nodes.append(None)
        total = middle[members].sum(axis=0)
        norm = float(np.linalg.norm(total))
        centre = total / norm if norm > 1e-6 else middle[members[0]]
        angle = np.arccos(np.clip(middle[members] @ centre, -1.0, 1.0)) + half[members]
        radius = float(angle.max()) + CAP_MARGIN_RAD
        axis, spread = cone(members)
        if len(members) == 1 or (len(members) <= LEAF_ARCS and spread <= LEAF_CONE_RAD):
            nodes[node] = (centre, radius, -1, -1, len(order), len(members), axis, spread)
            order.extend(members.tolist())
            return node
        wide = middle[members].max(axis=0) - middle[members].min(axis=0)
        ranked = members[np.argsort(middle[members, int(np.argmax(wide))], kind="stable")]
        first = len(order)
        left = build(ranked[:len(ranked) // 2])
        right = build(ranked[len(ranked) // 2:])
        nodes[node] = (centre, radius, left, right, first, len(members), axis, spread)
        return node

    build(np.arange(len(edge_faces)))
    return nodes, order, 2.0 * half, float(np.sin(2.0 * half).min())


def _face_order(hull: Hull) -> tuple[np.ndarray, np.ndarray]:
    """The faces in the order of a spanning tree over shared edges grown from face 0, each
    attached to the neighbour whose normal is closest to its own (Prim's algorithm), and each
    one's parent: a face's support search starts from its parent's support, a step or two
    away even around a many-sided head's caps (a hub face would be a poor parent)."""
    import heapq

    normals = hull.face_normals
    neighbours = [[] for _ in range(hull.n_faces)]
    for f0, f1 in hull.edge_faces.tolist():
        neighbours[f0].append(f1)
        neighbours[f1].append(f0)
    parent = np.full(hull.n_faces, -2, np.int64)
    order: list[int] = []
    heap = [(0.0, 0, -1)]
    while heap:
        _, face, up = heapq.heappop(heap)
        if parent[face] != -2:
            continue
        parent[face] = up
        order.append(face)
        for other in neighbours[face]:
            if parent[other] == -2:
                heapq.heappush(heap, (-float(normals[face] @ normals[other]), other, face))
    order = np.array(order, np.int64)
    return order, parent[order]


def _flatness(hull: Hull) -> float:
    """How far (m) a vertex lies outside a face plane, or a face's loop off its plane."""
    height = hull.vertices @ hull.face_normals.T - hull.face_offsets  # (V, F), <= 0 inside
    off = max(float(height.max()), 0.0)
    for f in range(hull.n_faces):
        off = max(off, float(np.abs(height[hull.face_loops[f, :hull.face_counts[f]], f]).max()))
    return off


def _hull_rows(hull: Hull) -> dict:
    """One hull's rows of every table (its own indices)."""
    v, e = len(hull.vertices), hull.n_edges
    counts = hull.face_counts
    loops = [hull.face_loops[f, :counts[f]] for f in range(hull.n_faces)]
    adjacency = [[] for _ in range(v)]
    for edge, (p, q) in enumerate(hull.edges.tolist()):
        adjacency[p].append((q, edge))
        adjacency[q].append((p, edge))
    faces_of = [[] for _ in range(v)]
    for f, loop in enumerate(loops):
        for vertex in loop.tolist():
            faces_of[vertex].append(f)
    pairs = np.stack([hull.face_normals[hull.edge_faces[:, 0]],
                      hull.face_normals[hull.edge_faces[:, 1]]], axis=1)
    directions = hull.vertices[hull.edges[:, 1]] - hull.vertices[hull.edges[:, 0]]
    lengths = np.linalg.norm(directions, axis=1)
    directions /= lengths[:, None]
    nodes, tree_edge, angle, arc_min_sin = _arc_tree(hull.face_normals, hull.edge_faces,
                                                       directions)
    order, parent = _face_order(hull)
    centre = hull.vertices.mean(axis=0)
    reach = float(np.abs(hull.vertices).sum(axis=1).max())
    flat = _flatness(hull)
    convex = flat <= CLIMB_FLAT_TOL_REL * reach
    return {
        "centre": centre, "half_extent": hull.half_extent, "reach": reach,
        "radius": float(np.linalg.norm(hull.vertices - centre, axis=1).max()), "flat": flat,
        "convex": convex, "climb": convex and v >= CLIMB_MIN_VERTICES,
        "arc_min_sin": arc_min_sin, "longest_edge": float(lengths.max()),
        "edge_angle": np.stack([np.cos(angle), np.sin(angle), np.tan(0.5 * angle),
                                angle / np.sin(angle)], axis=1), "edge_dir": directions,
        "vertices": hull.vertices,
        "adjacency_count": [len(a) for a in adjacency],
        "adjacency_vertex": [p for a in adjacency for p, _ in a],
        "adjacency_edge": [edge for a in adjacency for _, edge in a],
        "vertex_face_count": [len(f) for f in faces_of],
        "vertex_face": [f for faces in faces_of for f in sorted(faces)],
        "face_normals": hull.face_normals, "face_offsets": hull.face_offsets,
        "face_frames": hull.face_frames, "loop_count": counts,
        "loop_vertex": np.concatenate(loops),
        "side_planes": np.concatenate([hull.side_planes[f, :counts[f]]
                                       for f in range(hull.n_faces)]),
        "face_order": order, "face_parent": parent, "edges": hull.edges,
        "edge_faces": hull.edge_faces,
        "edge_arcs": np.cross(pairs[:, 1], pairs[:, 0]),  # the solver's arc normals, as before
        "nodes": nodes, "tree_edge": tree_edge, "n_vertices": v, "n_faces": hull.n_faces,
        "n_edges": e, "n_nodes": len(nodes), "width": int(counts.max()),
    }


def _starts(counts) -> np.ndarray:
    out = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(counts, out=out[1:])
    return out


def _build(hulls: tuple[Hull, ...]) -> HullTable:
    rows = [_hull_rows(h) for h in hulls]
    node_rows = [node for r in rows for node in r["nodes"]]
    tree_base = _starts([r["n_edges"] for r in rows])
    node_first = np.array([node[4] + tree_base[k] for k, r in enumerate(rows)
                           for node in r["nodes"]], np.int64)
    radius = np.array([n[1] for n in node_rows])

    def joined(name, dtype=np.float64):
        return np.ascontiguousarray(np.concatenate([np.asarray(r[name], dtype).reshape(
            (-1,) + np.shape(rows[0][name])[1:]) for r in rows]))

    arrays = HullArrays(
        vertex_start=_starts([r["n_vertices"] for r in rows]),
        face_start=_starts([r["n_faces"] for r in rows]),
        edge_start=_starts([r["n_edges"] for r in rows]),
        node_start=_starts([r["n_nodes"] for r in rows]),
        centre=np.array([r["centre"] for r in rows]),
        half_extent=np.array([r["half_extent"] for r in rows], np.float64),
        reach=np.array([r["reach"] for r in rows]),
        radius=np.array([r["radius"] for r in rows]),
        flat=np.array([r["flat"] for r in rows]),
        convex=np.array([r["convex"] for r in rows], np.bool_),
        climb=np.array([r["climb"] for r in rows], np.bool_),
        arc_min_sin=np.array([r["arc_min_sin"] for r in rows]),
        longest_edge=np.array([r["longest_edge"] for r in rows]),
        vertices=joined("vertices"),
        adjacency_start=_starts(np.concatenate([r["adjacency_count"] for r in rows])),
        adjacency_vertex=joined("adjacency_vertex", np.int64),
        adjacency_edge=joined("adjacency_edge", np.int64),
        vertex_face_start=_starts(np.concatenate([r["vertex_face_count"] for r in rows])),
        vertex_face=joined("vertex_face", np.int64),
        face_normals=joined("face_normals"), face_offsets=joined("face_offsets"),
        face_frames=joined("face_frames"),
        loop_start=_starts(np.concatenate([r["loop_count"] for r in rows])),
        loop_vertex=joined("loop_vertex", np.int64), side_planes=joined("side_planes"),
        face_order=joined("face_order", np.int64), face_parent=joined("face_parent", np.int64),
        edges=joined("edges", np.int64), edge_faces=joined("edge_faces", np.int64),
        edge_arcs=joined("edge_arcs"), edge_angle=joined("edge_angle"),
        edge_dir=joined("edge_dir"),
        node_centre=np.array([n[0] for n in node_rows], np.float64).reshape(-1, 3),
        node_radius=radius, node_cos=np.cos(radius), node_sin=np.sin(radius),
        node_left=np.array([n[2] for n in node_rows], np.int64),
        node_right=np.array([n[3] for n in node_rows], np.int64),
        node_first=node_first, node_count=np.array([n[5] for n in node_rows], np.int64),
        node_dir=np.array([n[6] for n in node_rows], np.float64).reshape(-1, 3),
        node_cone_cos=np.cos([n[7] for n in node_rows]),
        node_cone_sin=np.sin([n[7] for n in node_rows]),
        tree_edge=np.concatenate([np.asarray(r["tree_edge"], np.int64) for r in rows]))
    for array in arrays:
        array.setflags(write=False)
    widest = {"V": max(r["n_vertices"] for r in rows), "F": max(r["n_faces"] for r in rows),
              "E": max(r["n_edges"] for r in rows), "L": max(r["width"] for r in rows),
              "N": max(r["n_nodes"] for r in rows)}
    n_faces = np.array([r["n_faces"] for r in rows], np.int64)
    n_edges = np.array([r["n_edges"] for r in rows], np.int64)
    return HullTable(hulls, arrays, n_faces, n_edges, widest)


_CACHE: dict[tuple[int, ...], HullTable] = {}


def _cached(cache: dict, hulls: tuple, build):
    """``build(hulls)``, cached in ``cache`` by the hulls' identities; the entry holds the hulls
    (``.hulls``), so an identity is never reused while its entry lives."""
    key = tuple(id(h) for h in hulls)
    found = cache.get(key)
    if found is not None and all(a is b for a, b in zip(found.hulls, hulls)):
        return found
    found = build(hulls)
    if len(cache) >= CACHED_STACKS:
        cache.pop(next(iter(cache)))
    cache[key] = found
    return found


def stack_hulls(hulls, cached: bool = True) -> HullTable:
    """The :class:`HullTable` of a sequence of hulls, in order: cached, unless ``cached`` is
    False (a body built for one request stays out of the shared cache)."""
    hulls = tuple(hulls)
    return _cached(_CACHE, hulls, _build) if cached else _build(hulls)


@dataclass(frozen=True, eq=False)
class SizeClasses:
    """A body's hulls as the compound oracle reads them: ``stacks[klass[p]]`` holds part p's
    hull at ``slot[p]``. With flat tables nothing is padded, so one table serves every part
    (one class; the split by size that kept padding cheap is gone)."""

    hulls: tuple[Hull, ...]  # the body's hulls (their identities key the cache)
    stacks: tuple[HullTable, ...]  # one table
    klass: np.ndarray  # (P,) zeros
    slot: np.ndarray  # (P,) each hull's index in the table

    @property
    def table(self) -> HullTable:
        """The body's one table."""
        return self.stacks[0]


_CLASSES: dict[tuple[int, ...], SizeClasses] = {}


def _classes(hulls: tuple, cached: bool = True) -> SizeClasses:
    table = stack_hulls(hulls, cached)
    return SizeClasses(hulls, (table,), np.zeros(len(hulls), np.int64),
                       np.arange(len(hulls), dtype=np.int64))


def size_classes(hulls, cached: bool = True) -> SizeClasses:
    """The :class:`SizeClasses` of a body's hulls (in order), cached unless ``cached`` is
    False (a body built for one request)."""
    if not cached:
        return _classes(tuple(hulls), cached=False)
    return _cached(_CLASSES, tuple(hulls), _classes)

