"""Parts of a compound body and their validation (issue #20, step 1).

A compound body is a list of convex parts, each placed in the body's frame (metres, the body's
centre at the origin, no rotation of its own):

* :class:`BoxPart`: a box, ``size`` (full edges) at ``centre``;
* :class:`ConvexPart`: a convex polyhedron given by its vertices (the hull of the points; a mesh
  file is loaded elsewhere and replaced by its hull before it gets here).

Parts of one body may overlap: a container's body box overlaps its corner castings. Validation
(:func:`validate_parts`) refuses, with the part's name in the message,

* sizes outside the solver's domain (:mod:`impactnet.models.domain`),
* a flat or degenerate polyhedron (its points span less than a volume: the smallest extent
  across them below :data:`FLAT_TOL_REL` of the largest),
* a part wholly inside a box part of the same body: it can never touch anything.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.domain import SIZE_MAX_M, SIZE_MIN_M

#: A polyhedron is flat when its smallest extent (the smallest singular value of its centred
#: points, times 2) is below this fraction of its largest: 1e-9, far below any real part's
#: aspect (a 1 mm plate of 10 m is 1e-4) and far above round-off.
FLAT_TOL_REL = 1e-9
#: Slack (x the containing box's largest edge) of the "wholly inside" test, so that a part that
#: only shares a face with the box is not called inside by round-off.
INSIDE_TOL_REL = 1e-12


class PartError(ValueError):
    """A part cannot be used; ``part`` names it."""

    def __init__(self, part: str, reason: str):
        self.part = part
        super().__init__(f"part {part!r}: {reason}")


@dataclass(frozen=True)
class BoxPart:
    """A box part, axis-aligned in the body's frame."""

    name: str  # unique within its body
    size: tuple[float, float, float]  # full edge lengths (m), > 0
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)  # in the body frame (m)

    def vertices(self) -> np.ndarray:
        """The 8 corners, shape (8, 3), metres, body frame."""
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        return np.asarray(self.centre) + 0.5 * signs * np.asarray(self.size)


@dataclass(frozen=True)
class ConvexPart:
    """A convex polyhedron part: the hull of ``points`` (body frame, metres)."""

    name: str  # unique within its body
    points: tuple[tuple[float, float, float], ...]  # >= 4 points that span a volume

    def vertices(self) -> np.ndarray:
        """The points, shape (k, 3), metres, body frame."""
        return np.asarray(self.points, dtype=np.float64)


Part = BoxPart | ConvexPart


def bounds(part: Part) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds ``(lo, hi)`` of a part in the body frame, each (3,), metres."""
    v = part.vertices()
    return v.min(axis=0), v.max(axis=0)


def _check_extent(part: Part) -> None:
    if isinstance(part, ConvexPart):
        _check_volume(part)
    lo, hi = bounds(part)
    extent = hi - lo
    if not np.isfinite(extent).all():
        raise PartError(part.name, "coordinates must be finite")
    if extent.min() < SIZE_MIN_M or extent.max() > SIZE_MAX_M:
        raise PartError(part.name, f"extents {extent.tolist()} m outside [{SIZE_MIN_M:g}, "
                                   f"{SIZE_MAX_M:g}] m")


def _check_volume(part: ConvexPart) -> None:
    points = part.vertices()
    if points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
        raise PartError(part.name, "points must be finite (x, y, z) triples")
    if len(points) < 4:
        raise PartError(part.name, f"a polyhedron needs >= 4 points, got {len(points)}")
    spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if spread[-1] <= FLAT_TOL_REL * spread[0]:
        raise PartError(part.name, "the points are flat or degenerate (they span no volume)")


def _inside_box(inner: Part, box: BoxPart) -> bool:
    """Whether every vertex of ``inner`` lies in ``box`` (within :data:`INSIDE_TOL_REL`)."""
    slack = INSIDE_TOL_REL * max(box.size)
    half = 0.5 * np.asarray(box.size) + slack
    return bool((np.abs(inner.vertices() - np.asarray(box.centre)) <= half).all())


def validate_parts(body: str, parts: list[Part] | tuple[Part, ...]) -> tuple[Part, ...]:
    """The parts of ``body`` checked (module docstring); returns them as a tuple.

    Raises
    ------
    PartError
        A bad part, naming it (and the body in the message).
    """
    if not parts:
        raise PartError(body, "a compound body needs at least one part")
    names = [p.name for p in parts]
    if len(set(names)) != len(names):
        raise PartError(body, f"part names must be unique, got {names}")
    for part in parts:
        _check_extent(part)
    for part in parts:
        for box in parts:
            if box is not part and isinstance(box, BoxPart) and _inside_box(part, box):
                raise PartError(part.name, f"lies wholly inside part {box.name!r} of body "
                                           f"{body!r}: it can never touch anything")
    return tuple(parts)
