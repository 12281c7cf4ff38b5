"""One hull's rows of the flat hull tables (:mod:`impactnet.models.compound.hull_stack`): its
adjacency, the faces of each vertex, its face loops and side planes, the spanning tree of its
faces (support searches start from a face's parent's support) and the binary tree of its
Gauss-map arcs (spherical caps and cones of edge directions) that the separating-axis test
walks (:mod:`impactnet.models.compound.convex_sat`)."""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import Hull

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


def hull_rows(hull: Hull) -> dict:
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
