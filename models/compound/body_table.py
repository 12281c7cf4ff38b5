"""The per-body tables the compound oracle needs, built once per parts tuple and cached.

A body's parts are a tuple of frozen dataclasses; hashing it on every call (71 parts with
their vertex tuples at detail 2) would cost as much as a single-pose query. The cache is keyed
on the tuple's identity instead (scenes and generators hand out the same tuple each time) and
holds the tuple itself, so an identity is never reused while its entry lives.
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.broadphase import groups_of
from impactnet.models.compound.hull import Hull, hull_of
from impactnet.models.compound.parts import BoxPart, bounds

#: Bodies kept in the cache (least recently used dropped first): a scene has a handful.
CACHED_BODIES = 64


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


_CACHE: OrderedDict[int, BodyTable] = OrderedDict()


def _partners(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR of the parts whose bounds overlap each part's (itself excluded)."""
    overlap = ((lo[:, None] < hi[None]) & (lo[None] < hi[:, None])).all(axis=2)
    np.fill_diagonal(overlap, False)
    start = np.zeros(len(lo) + 1, np.int64)
    np.cumsum(overlap.sum(axis=1), out=start[1:])
    return start, np.nonzero(overlap)[1]


def body_table(parts) -> BodyTable:
    """The (cached) :class:`BodyTable` of a tuple of validated parts."""
    table = _CACHE.get(id(parts))
    if table is not None and table.parts is parts:
        _CACHE.move_to_end(id(parts))
        return table
    parts = tuple(parts)
    lo = np.array([bounds(p)[0] for p in parts])
    hi = np.array([bounds(p)[1] for p in parts])
    group, members = groups_of(parts)
    table = BodyTable(parts, 0.5 * (lo + hi), hi - lo,
                      np.array([isinstance(p, BoxPart) for p in parts]), group, tuple(members),
                      tuple(hull_of(p) for p in parts), _partners(lo, hi))
    _CACHE[id(parts)] = table
    while len(_CACHE) > CACHED_BODIES:
        _CACHE.popitem(last=False)
    return table
