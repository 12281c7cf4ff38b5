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
* the Gauss-map tree: a binary tree over the edges' Gauss-map arcs (great-circle arcs between the
  two faces' normals), each node a spherical cap that contains its arcs and a cone that contains its
  edges' directions (as lines, ``node_dir``, ``node_cone_*``), leaves of at most :data:`LEAF_ARCS`
  arcs whose directions lie within :data:`LEAF_CONE_RAD` of each other; each node's edges listed
  from ``node_first`` in ``tree_edge`` (a subtree's edges are contiguous). The separating-axis test
  visits only the pairs of nodes whose caps meet and whose edges may separate the hulls more than
  every face (:mod:`impactnet.models.compound.convex_sat`).

Vertex, face, edge and node indices inside the tables are each hull's own (add the hull's
``*_start`` for a position in the arrays); CSR starts (``adjacency_start``, ``vertex_face_start``,
``loop_start``, ``node_first``) are positions in the arrays. Feature ids stay each hull's own.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from impactnet.models.compound.hull import Hull
from impactnet.models.compound.hull_tree import (  # noqa: F401 - the tables' constants
    CAP_MARGIN_RAD,
    CLIMB_FLAT_TOL_REL,
    CLIMB_MIN_VERTICES,
    LEAF_ARCS,
    LEAF_CONE_RAD,
    hull_rows,
)

#: Tables kept (keyed by the hulls' identities; a scene's bodies need a few).
CACHED_STACKS = 256

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


def _starts(counts) -> np.ndarray:
    out = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(counts, out=out[1:])
    return out


def _build(hulls: tuple[Hull, ...]) -> HullTable:
    rows = [hull_rows(h) for h in hulls]
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

