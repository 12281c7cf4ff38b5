"""The paper's polygon method: both boxes as triangle meshes, collided by FCL's BVH traversal.

Section II of the paper: "a cube face [is] split into a grid of n by n squares, and then each
square is subdivided into two triangles by its diagonal. The impact region would be determined
by detecting the intersections of pairs of triangles. Once the involved triangles are known,
the precise impact point can be calculated."

Stages, per pair:

1. Meshes (built once per body size and n, not timed, as a simulator builds them once): every
   face of a box is an n x n grid of rectangles (edges ``L_u / n`` by ``L_v / n``), each split
   along one diagonal into two triangles wound counter-clockwise seen from outside, so
   ``12 n^2`` triangles per box; one ``fcl.BVHModel`` (python-fcl's default bounding volume,
   OBBRSS) per mesh.
2. ``fcl.collide`` with ``enable_contact=True`` and :data:`MAX_CONTACTS`: FCL reports one
   contact per intersecting triangle pair and per "deepest point" of that pair (1-2 per pair):
   the vertices of one triangle that lie deepest below the other triangle's plane, the depth
   of that vertex below that plane, and the plane's normal (``n_A`` of A's triangle, or
   ``-n_B`` of B's), oriented from A towards B.
3. Reduction to one impact point and one normal (:func:`reduce_contacts`, :data:`RULE`):
   the plain mean of the contact points and the normalised mean of the contact normals. FCL's
   per-pair depth is that of a whole grid triangle below the other's infinite plane, up to a
   cell deep, so weighting by it (as a penalty method would) was measured to be worse at
   coarse grids; the other reductions (:data:`VARIANTS`) are scored beside it in the report.
   The normal can only be a mixture of triangle normals (face normals of A or B): no grid
   produces an edge-edge normal.

Nothing is NaN: a pair without intersecting triangles reports ``colliding = False``, the
centres' midpoint and a zero normal (a *miss* when the exact solver says that they touch).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: ``CollisionRequest.num_max_contacts``: large enough never to truncate (n = 64 on two
#: nearly parallel container faces reports a few thousand triangle pairs).
MAX_CONTACTS = 1_000_000
#: Grid sizes of the paper's sweep (squares per face edge).
GRID_SIZES = (1, 2, 4, 8, 16, 32, 64)
#: How the point and normal are derived from FCL's triangle-pair contacts (the paper says only
#: that "once the involved triangles are known, the precise impact point can be calculated").
RULE = ("point: mean of the triangle-pair contact points; normal: mean of the triangle-pair "
        "contact normals, normalised (every intersecting triangle pair counts once)")
#: Other reductions of the same contacts, scored beside the rule (:func:`rule_variants`).
VARIANTS = {
    "mean": "the rule: plain means of points and normals",
    "depth_weighted": "points and normals weighted by FCL's triangle-pair depths (a penalty "
                      "method's resultant force and its point of application)",
    "deepest_pair": "point and normal of the most penetrating triangle pair",
    "majority_normal": "mean point; the normal reported by most triangle pairs",
}
#: Normals whose components agree to this many decimals are "the same" (majority vote).
NORMAL_DECIMALS = 9


@dataclass(frozen=True)
class PolygonConfig:
    """One polygon method: the grid and FCL's request."""

    n: int  # squares per face edge (each square = two triangles)
    max_contacts: int = MAX_CONTACTS  # CollisionRequest.num_max_contacts


def grid_mesh(size, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Triangle mesh of a box centred at the origin, each face an n x n grid.

    Parameters
    ----------
    size : array_like, shape (3,)
        Full edge lengths in metres.
    n : int
        Squares per face edge, >= 1.

    Returns
    -------
    vertices : ndarray, shape (6 (n + 1)^2, 3)
        Metres, in the box frame (edge vertices are repeated per face: FCL needs no sharing).
    triangles : ndarray of int, shape (12 n^2, 3)
        Vertex indices, counter-clockwise seen from outside (outward normals).
    """
    half = 0.5 * np.asarray(size, dtype=np.float64)
    s = np.linspace(-1.0, 1.0, n + 1)
    grid_u, grid_v = np.meshgrid(s, s, indexing="ij")
    index = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]
    quads = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                            np.stack([a, c, d], -1).reshape(-1, 3)])
    vertices, triangles = [], []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3  # (u, v, axis) is right-handed
        for sign in (1.0, -1.0):
            face = np.empty((n + 1, n + 1, 3))
            face[..., axis] = sign * half[axis]
            face[..., u], face[..., v] = grid_u * half[u], grid_v * half[v]
            offset = sum(len(x) for x in vertices)
            triangles.append(offset + (quads if sign > 0 else quads[:, ::-1]))
            vertices.append(face.reshape(-1, 3))
    return np.concatenate(vertices), np.concatenate(triangles)


def cell_diagonal(size_a, size_b, n: int) -> np.ndarray:
    """The paper's bound: the largest grid-cell diagonal of either box, metres, shape (m,).

    A face of edges ``L_u, L_v`` has cells of diagonal ``sqrt(L_u^2 + L_v^2) / n``; the largest
    is on the face spanned by a box's two longest edges. For a cube of edge L: ``sqrt(2) L / n``.
    """
    def largest(size):
        edges = np.sort(np.atleast_2d(np.asarray(size, dtype=np.float64)), axis=1)
        return np.hypot(edges[:, 1], edges[:, 2]) / n

    return np.maximum(largest(size_a), largest(size_b))


def bvh_model(size, n: int):
    """An ``fcl.BVHModel`` (OBBRSS) of :func:`grid_mesh`."""
    import fcl

    vertices, triangles = grid_mesh(size, n)
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(triangles))
    model.addSubModel(vertices, triangles)
    model.endModel()
    return model


def _unit(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    length = np.sqrt(v @ v)
    return v / length if length > 1e-12 else fallback


def reduce_contacts(points: np.ndarray, normals: np.ndarray, depths: np.ndarray):
    """One impact point and normal from FCL's triangle-pair contacts (the rule :data:`RULE`).

    Parameters
    ----------
    points, normals : ndarray, shape (k, 3)
        Contact points (metres, world) and unit normals (A towards B), k >= 1.
    depths : ndarray, shape (k,)
        Penetration depths (metres, >= 0); not used by the rule (see :func:`rule_variants`).

    Returns
    -------
    point : ndarray, shape (3,)
    normal : ndarray, shape (3,)
        Unit; if the normals cancel out, the normal of the deepest contact.
    """
    deepest = normals[int(np.argmax(depths))]
    return points.mean(axis=0), _unit(normals.mean(axis=0), deepest)


def rule_variants(points: np.ndarray, normals: np.ndarray, depths: np.ndarray) -> dict:
    """Every reduction of :data:`VARIANTS`: name -> (point (3,), unit normal (3,))."""
    deepest = int(np.argmax(depths))
    total = depths.sum()
    weights = depths / total if total > 0.0 else np.full(len(depths), 1.0 / len(depths))
    rounded, counts = np.unique(np.round(normals, NORMAL_DECIMALS), axis=0,
                                return_counts=True)
    mean_point, mean_normal = reduce_contacts(points, normals, depths)
    return {
        "mean": (mean_point, mean_normal),
        "depth_weighted": (weights @ points, _unit(weights @ normals, normals[deepest])),
        "deepest_pair": (points[deepest], normals[deepest]),
        "majority_normal": (mean_point, _unit(rounded[int(np.argmax(counts))],
                                              normals[deepest])),
    }


class PolygonMethod:
    """The polygon method at one grid size, called pair by pair (FCL has no batch API).

    Meshes are built lazily, once per distinct body size, and reused.
    """

    def __init__(self, config: PolygonConfig):
        import fcl

        self.config = config
        self.name = f"polygon n={config.n}"
        self._fcl = fcl
        self._request = fcl.CollisionRequest(num_max_contacts=config.max_contacts,
                                             enable_contact=True)
        self._models: dict[tuple, object] = {}  # size -> BVHModel
        self._objects: dict[tuple, object] = {}  # (slot, size) -> CollisionObject
        # (points, normals, depths) of the latest colliding pair (diagnostics, untimed use)
        self.last_contacts: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def _object(self, size, slot: int):
        size_key = tuple(float(x) for x in size)
        key = (slot, *size_key)
        if key not in self._objects:
            if size_key not in self._models:
                self._models[size_key] = bvh_model(size_key, self.config.n)
            self._objects[key] = self._fcl.CollisionObject(self._models[size_key])
        return self._objects[key]

    def prepare(self, sizes) -> None:
        """Build the meshes of every (n, 3) size in ``sizes`` (both slots) ahead of timing."""
        for size in np.unique(np.asarray(sizes, dtype=np.float64).reshape(-1, 3), axis=0):
            self._object(size, 0), self._object(size, 1)

    def one(self, size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
        """One pair: ``(colliding, point (3,), normal (3,), contact count)``."""
        fcl = self._fcl
        obj_a, obj_b = self._object(size_a, 0), self._object(size_b, 1)
        obj_a.setTransform(fcl.Transform(quaternion_a, position_a))  # q = (w, x, y, z)
        obj_b.setTransform(fcl.Transform(quaternion_b, position_b))
        result = fcl.CollisionResult()
        fcl.collide(obj_a, obj_b, self._request, result)
        contacts = result.contacts
        if not contacts:
            self.last_contacts = None
            midpoint = 0.5 * (np.asarray(position_a) + np.asarray(position_b))
            return False, midpoint, np.zeros(3), 0
        points = np.array([c.pos for c in contacts])
        normals = np.array([c.normal for c in contacts])
        depths = np.array([c.penetration_depth for c in contacts])
        self.last_contacts = (points, normals, depths)
        point, normal = reduce_contacts(points, normals, depths)
        return True, point, normal, len(contacts)
