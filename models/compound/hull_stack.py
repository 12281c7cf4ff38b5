"""Several hulls as one padded table, so that the convex solver answers rows of different part
pairs in one vectorised call (the compound oracle's narrowphase, and a single pose's handful of
part pairs, which would otherwise pay the solver's fixed NumPy cost once per pair).

A :class:`HullStack` holds H hulls (:class:`impactnet.models.compound.hull.Hull`) padded to the
largest counts; a row of the solver names its hull by an index into the stack. Padding never
changes an answer:

* vertices: copies of vertex 0 (no new extreme along any axis; ``argmax`` and ``argmin`` return
  the first of equal values, a real vertex);
* faces: copies of face 0 (normal, offset, loop, frame, side planes), after the real ones, so
  the tie rule's lowest index and every ``argmax`` pick a real face; no vertex lies on them
  (``vertex_faces`` false);
* edges and fan triangles: copies of the first, marked invalid (``edge_valid``,
  ``triangle_valid``), and never used;
* face loops: the last vertex repeated, as :class:`Hull` pads its own loops; side planes:
  ``(0, 0, 0, 1)`` (nothing outside), as :class:`Hull` pads its own.

Feature ids stay each hull's own (``n_faces`` and ``n_edges`` per hull, not the padded counts).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.hull import Hull

#: Stacks kept (keyed by the hulls' identities; a scene's bodies need a few).
CACHED_STACKS = 256


@dataclass(frozen=True, eq=False)
class HullStack:
    """H hulls padded to common counts (module docstring); body frames, metres."""

    hulls: tuple[Hull, ...]  # the hulls themselves (their identities key the cache)
    vertices: np.ndarray  # (H, V, 3)
    centre: np.ndarray  # (H, 3) the mean of each hull's own vertices
    face_normals: np.ndarray  # (H, F, 3) outward unit normals
    face_offsets: np.ndarray  # (H, F) n . x of each face's plane (m)
    face_loops: np.ndarray  # (H, F, L) vertex indices, padded by repeating the last
    face_counts: np.ndarray  # (H, F) vertices per face
    face_frames: np.ndarray  # (H, F, 3, 3) origin, in-plane axes u, w of each face
    side_planes: np.ndarray  # (H, F, L, 4) each face's sides in its frame
    edges: np.ndarray  # (H, E, 2) vertex indices
    edge_valid: np.ndarray  # (H, E) bool: a real edge
    edge_normals: np.ndarray  # (H, E, 2, 3) the normals of the two faces at each edge
    edge_arcs: np.ndarray  # (H, E, 3) second x first of those normals (the Gauss-map arc's)
    edge_of_vertices: np.ndarray  # (H, V, V) edge joining two vertices, -1 if none
    triangles: np.ndarray  # (H, T, 3) fan triangles' vertices
    triangle_face: np.ndarray  # (H, T) the face of each triangle
    triangle_valid: np.ndarray  # (H, T) bool: a real triangle
    vertex_faces: np.ndarray  # (H, V, F) bool: the vertex lies on the face
    half_extent: np.ndarray  # (H,) largest half-extent of each hull's bounds (m)
    n_faces: np.ndarray  # (H,) each hull's own face count (feature ids)
    n_edges: np.ndarray  # (H,) each hull's own edge count (feature ids)

    @property
    def width(self) -> dict[str, int]:
        """The padded counts: vertices, faces, edges, triangles, loop width."""
        return {"V": self.vertices.shape[1], "F": self.face_normals.shape[1],
                "E": self.edges.shape[1], "T": self.triangles.shape[1],
                "L": self.face_loops.shape[2]}


def _repeat_first(array: np.ndarray, size: int) -> np.ndarray:
    """``array`` grown along axis 0 to ``size`` entries with copies of its first."""
    extra = size - len(array)
    return np.concatenate([array, np.repeat(array[:1], extra, axis=0)]) if extra else array


def _padded(arrays: list[np.ndarray], size: int) -> np.ndarray:
    """The arrays grown to ``size`` entries each (:func:`_repeat_first`), stacked."""
    return np.stack([_repeat_first(a, size) for a in arrays])


def _stack_loops(hulls, faces: int, width: int) -> np.ndarray:
    """Face loops (H, F, L): each loop's last vertex repeated to L, face 0's loop for pads."""
    out = []
    for hull in hulls:
        loops = hull.face_loops
        loops = np.concatenate([loops, np.repeat(loops[:, -1:], width - loops.shape[1], 1)], 1)
        out.append(_repeat_first(loops, faces))
    return np.stack(out)


def _stack_sides(hulls, faces: int, width: int) -> np.ndarray:
    """Side planes (H, F, L, 4): (0, 0, 0, 1) past each face's sides, face 0's for pads."""
    out = []
    for hull in hulls:
        sides = hull.side_planes
        keep = np.tile(np.array([0.0, 0.0, 0.0, 1.0]), (len(sides), width - sides.shape[1], 1))
        out.append(_repeat_first(np.concatenate([sides, keep], axis=1), faces))
    return np.stack(out)


def _valid(counts, size: int) -> np.ndarray:
    return np.arange(size)[None, :] < np.asarray(counts)[:, None]


def _square(array: np.ndarray, size: int, fill) -> np.ndarray:
    out = np.full((size, size), fill, array.dtype)
    out[:len(array), :len(array)] = array
    return out


def _build(hulls: tuple[Hull, ...]) -> HullStack:
    v = max(len(h.vertices) for h in hulls)
    f = max(h.n_faces for h in hulls)
    e = max(h.n_edges for h in hulls)
    t = max(len(h.triangles) for h in hulls)
    width = max(h.face_loops.shape[1] for h in hulls)
    edge_normals = [np.stack([h.face_normals[h.edge_faces[:, 0]],
                              h.face_normals[h.edge_faces[:, 1]]], axis=1) for h in hulls]
    arcs = [np.cross(n[:, 1], n[:, 0]) for n in edge_normals]
    vertex_faces = np.zeros((len(hulls), v, f), bool)
    for k, h in enumerate(hulls):
        vertex_faces[k, :len(h.vertices), :h.n_faces] = h.vertex_faces
    stack = HullStack(
        hulls,
        _padded([h.vertices for h in hulls], v),
        np.stack([h.vertices.mean(axis=0) for h in hulls]),
        _padded([h.face_normals for h in hulls], f),
        _padded([h.face_offsets for h in hulls], f),
        _stack_loops(hulls, f, width),
        _padded([h.face_counts for h in hulls], f),
        _padded([h.face_frames for h in hulls], f),
        _stack_sides(hulls, f, width),
        _padded([h.edges for h in hulls], e),
        _valid([h.n_edges for h in hulls], e),
        _padded(edge_normals, e),
        _padded(arcs, e),
        np.stack([_square(h.edge_of_vertices, v, -1) for h in hulls]),
        _padded([h.triangles for h in hulls], t),
        _padded([h.triangle_face for h in hulls], t),
        _valid([len(h.triangles) for h in hulls], t),
        vertex_faces,
        np.array([h.half_extent for h in hulls]),
        np.array([h.n_faces for h in hulls], np.int64),
        np.array([h.n_edges for h in hulls], np.int64))
    for name in stack.__dataclass_fields__:
        value = getattr(stack, name)
        if isinstance(value, np.ndarray):
            value.setflags(write=False)
    return stack


_CACHE: dict[tuple[int, ...], HullStack] = {}


def _cached(cache: dict, hulls: tuple, build):
    """``build(hulls)``, cached in ``cache`` by the hulls' identities; the entry holds the hulls
    (``.hulls``), so an identity is never reused while its entry lives. ``cache`` None: built,
    not cached."""
    if cache is None:
        return build(hulls)
    key = tuple(id(h) for h in hulls)
    found = cache.get(key)
    if found is not None and all(a is b for a, b in zip(found.hulls, hulls)):
        return found
    found = build(hulls)
    if len(cache) >= CACHED_STACKS:
        cache.pop(next(iter(cache)))
    cache[key] = found
    return found


def stack_hulls(hulls) -> HullStack:
    """The (cached) :class:`HullStack` of a sequence of hulls, in order."""
    return _cached(_CACHE, tuple(hulls), _build)


@dataclass(frozen=True, eq=False)
class SizeClasses:
    """A body's hulls split into stacks of similar size, so that padding stays cheap: a part
    pair of two small hulls is not padded to a 256-sided twistlock head's counts."""

    hulls: tuple[Hull, ...]  # the body's hulls (their identities key the cache)
    stacks: tuple[HullStack, ...]  # one stack per class, classes by increasing size
    klass: np.ndarray  # (P,) the class of each hull
    slot: np.ndarray  # (P,) each hull's index in its class's stack


def _size_class(hull: Hull) -> int:
    """log2 of the power of two at or above the hull's edge count (edge pairs cost the most)."""
    return int(np.ceil(np.log2(max(hull.n_edges, 1))))


_CLASSES: dict[tuple[int, ...], SizeClasses] = {}


def size_classes(hulls, cached: bool = True) -> SizeClasses:
    """The :class:`SizeClasses` of a body's hulls (in order), cached unless ``cached`` is
    False (a body built for one request)."""
    if not cached:
        return _classes(tuple(hulls), cached=False)
    return _cached(_CLASSES, tuple(hulls), _classes)


def _classes(hulls: tuple, cached: bool = True) -> SizeClasses:
    sizes = np.array([_size_class(h) for h in hulls])
    levels = np.unique(sizes)
    klass = np.searchsorted(levels, sizes)
    slot = np.zeros(len(hulls), np.int64)
    stacks = []
    for k in range(len(levels)):
        members = np.flatnonzero(klass == k)
        slot[members] = np.arange(len(members))
        chosen = tuple(hulls[i] for i in members)
        stacks.append(stack_hulls(chosen) if cached else _build(chosen))
    return SizeClasses(hulls, tuple(stacks), klass, slot)
