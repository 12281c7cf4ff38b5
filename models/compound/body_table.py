"""The per-body tables the compound oracle needs, built once per parts tuple and cached.

A body's parts are a tuple of frozen dataclasses; hashing it on every call (71 parts with
their vertex tuples at detail 2) would cost as much as a single-pose query. The cache is keyed
on the tuple's identity instead (scenes and generators hand out the same tuple each time) and
holds the tuple itself, so an identity is never reused while its entry lives.

Parts built for one request (a client's inline parts, a raw box size) are marked
:class:`TransientParts`: their tables, hulls and hull stacks stay out of the shared caches
(a client could otherwise fill them with its own large hulls) and live in a cache of
:data:`TRANSIENT_BODIES` entries of their own, long enough for one request.
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from impactnet.models.compound.broadphase import groups_of
from impactnet.models.compound.hull import Hull, build_hull, hull_of
from impactnet.models.compound.hull_stack import SizeClasses, size_classes
from impactnet.models.compound.parts import BoxPart, bounds

#: Bodies kept in the cache (least recently used dropped first): a scene has a handful.
CACHED_BODIES = 64
#: Transient bodies kept (the two of the request being solved).
TRANSIENT_BODIES = 2


class TransientParts(tuple):
    """The parts of a body built for one request (module docstring)."""


@dataclass(frozen=True, eq=False)  # hashed by identity: a key of the broadphase's caches
class BodyTable:
    """A body's parts as arrays (body frame, metres)."""

    parts: tuple  # the parts themselves
    centre: np.ndarray  # (P, 3) centres of the parts' bounds
    size: np.ndarray  # (P, 3) extents of the parts' bounds
    is_box: np.ndarray  # (P,) bool: a box part (its bounds are the part)
    group: np.ndarray  # (P,) broadphase group of each part
    members: tuple  # members of each group, arrays of part indices
    hulls: tuple[Hull, ...]  # the hull of every part (box parts keep the box's ids)
    partners: tuple  # CSR (start (P + 1,), part): the other parts whose bounds overlap each
    transient: bool = False  # built for one request: nothing derived from it is cached

    @cached_property
    def group_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(centres (G, 3), sizes (G, 3)) of the union of each group's part bounds."""
        lo = np.array([(self.centre[m] - 0.5 * self.size[m]).min(axis=0) for m in self.members])
        hi = np.array([(self.centre[m] + 0.5 * self.size[m]).max(axis=0) for m in self.members])
        return 0.5 * (lo + hi), hi - lo

    @cached_property
    def classes(self) -> SizeClasses:
        """The parts' hulls by size class
        (:func:`~impactnet.models.compound.hull_stack.size_classes`; a transient body's outside the
        shared cache)."""
        return size_classes(self.hulls, cached=not self.transient)

    @cached_property
    def packed(self):
        """The body as the compiled pipeline reads it
        (:func:`~impactnet.models.compound.flat_tables.body_set`), built once; it lives with this
        table (a transient body's too,
        outside any shared cache)."""
        from impactnet.models.compound.flat_tables import body_set

        return body_set(self)

    @cached_property
    def names(self) -> tuple[str, ...]:
        """The parts' names, in order."""
        return tuple(p.name for p in self.parts)

    @cached_property
    def hull_counts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(vertices, faces, edges) counts (P,) of the parts' hulls."""
        hulls = self.hulls
        return (np.array([len(h.vertices) for h in hulls], np.int64),
                np.array([h.n_faces for h in hulls], np.int64),
                np.array([h.n_edges for h in hulls], np.int64))


_CACHE: OrderedDict[int, BodyTable] = OrderedDict()
_TRANSIENT: OrderedDict[int, BodyTable] = OrderedDict()


def _partners(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR of the parts whose bounds overlap each part's (itself excluded)."""
    overlap = ((lo[:, None] < hi[None]) & (lo[None] < hi[:, None])).all(axis=2)
    np.fill_diagonal(overlap, False)
    start = np.zeros(len(lo) + 1, np.int64)
    np.cumsum(overlap.sum(axis=1), out=start[1:])
    return start, np.nonzero(overlap)[1]


def body_table(parts) -> BodyTable:
    """The (cached) :class:`BodyTable` of a tuple of validated parts."""
    transient = isinstance(parts, TransientParts)
    cache, size = (_TRANSIENT, TRANSIENT_BODIES) if transient else (_CACHE, CACHED_BODIES)
    table = cache.get(id(parts))
    if table is not None and table.parts is parts:
        cache.move_to_end(id(parts))
        return table
    if not transient:
        parts = tuple(parts)
    lo = np.array([bounds(p)[0] for p in parts])
    hi = np.array([bounds(p)[1] for p in parts])
    group, members = groups_of(parts)
    hull = build_hull if transient else hull_of
    table = BodyTable(parts, 0.5 * (lo + hi), hi - lo,
                      np.array([isinstance(p, BoxPart) for p in parts]), group, tuple(members),
                      tuple(hull(p) for p in parts), _partners(lo, hi), transient)
    cache[id(parts)] = table
    while len(cache) > size:
        cache.popitem(last=False)
    return table
