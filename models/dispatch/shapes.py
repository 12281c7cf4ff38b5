"""Bodies as the dispatcher sees them: a :class:`Shape` (a box, or a compound body's parts) and
the :class:`Pairs` of N poses that name two shapes each.

A box is a body of one part named ``box``; a scene object keeps its scene name, a raw size or a
client's inline parts have none. Features are named for every part: a box part's by the box's
fixed ids (``face +z``, ``edge x(+y,-z)``, ``vertex (+,-,+)``), a convex part's by its hull's
ids (``face 3``, ``edge 17``, ``vertex 40``: faces first, then edges, then vertices).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from impactnet.models.compound.body_table import TransientParts, body_table
from impactnet.models.compound.parts import BoxPart
from impactnet.models.geometry import box_features as bf

#: The name of a box body's one part.
BOX_PART = "box"


@dataclass(frozen=True, eq=False)
class Shape:
    """A body: its parts in its own frame (a box: one box part centred on its origin)."""

    parts: tuple  # BoxPart / ConvexPart, body frame (TransientParts: built for one request)
    name: str | None = None  # the scene object's name; None for a raw size or inline parts

    @classmethod
    def box(cls, size, name: str | None = None, transient: bool = True) -> Shape:
        """A box of full edge lengths ``size`` (3,), metres."""
        part = (BoxPart(BOX_PART, tuple(float(v) for v in size)),)
        return cls(TransientParts(part) if transient else part, name)

    @cached_property
    def is_box(self) -> bool:
        return len(self.parts) == 1 and isinstance(self.parts[0], BoxPart) and \
            self.parts[0].centre == (0.0, 0.0, 0.0)

    @property
    def size(self) -> tuple[float, float, float]:
        """A box's full edge lengths (only for :attr:`is_box`)."""
        return self.parts[0].size

    @property
    def part_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parts)

    @cached_property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(centre (3,), half extents (3,)) of the box around every part, body frame, m (a
        box's own, with no table built: a batch may hold many distinct box sizes)."""
        if self.is_box:
            return np.zeros(3), 0.5 * np.asarray(self.size, np.float64)
        table = body_table(self.parts)
        lo = (table.centre - 0.5 * table.size).min(axis=0)
        hi = (table.centre + 0.5 * table.size).max(axis=0)
        return 0.5 * (lo + hi), 0.5 * (hi - lo)

    @cached_property
    def sphere(self) -> tuple[np.ndarray, float]:
        """(centre (3,) in the body frame, radius): a sphere around every part."""
        centre, half = self.bounds
        return centre, float(np.linalg.norm(half))

    def feature(self, part: int, feature: int) -> tuple[str, str]:
        """(name, kind) of a feature id of part ``part``: kind face, edge, vertex or none."""
        if feature < 0:
            return "none", "none"
        if isinstance(self.parts[part], BoxPart):
            return str(bf.feature_name(feature)), str(bf.feature_kind(feature))
        hull = body_table(self.parts).hulls[part]
        faces, edges = hull.n_faces, hull.n_edges
        if feature < faces:
            return f"face {feature}", "face"
        if feature < faces + edges:
            return f"edge {feature - faces}", "edge"
        return f"vertex {feature - faces - edges}", "vertex"


@dataclass(frozen=True)
class Pairs:
    """N poses of pairs of shapes (world frame, metres, unit quaternions [w, x, y, z]); every
    column has n rows or one (broadcast)."""

    shapes: tuple[Shape, ...]  # the shapes the rows name
    shape_a: np.ndarray  # (n,) int64 index into shapes
    shape_b: np.ndarray
    position_a: np.ndarray  # (n, 3)
    quaternion_a: np.ndarray  # (n, 4)
    position_b: np.ndarray
    quaternion_b: np.ndarray

    def __len__(self) -> int:
        return max(len(c) for c in (self.shape_a, self.shape_b, self.position_a,
                                    self.quaternion_a, self.position_b, self.quaternion_b))

    def column(self, name: str) -> np.ndarray:
        """Column ``name`` broadcast to n rows."""
        values = getattr(self, name)
        return np.broadcast_to(values, (len(self),) + values.shape[1:])

    def poses(self, rows: np.ndarray) -> tuple[np.ndarray, ...]:
        """(position_a, quaternion_a, position_b, quaternion_b) of ``rows``."""
        return tuple(self.column(c)[rows] for c in ("position_a", "quaternion_a",
                                                     "position_b", "quaternion_b"))


def scene_shapes(scene) -> dict[str, Shape]:
    """The shape of every body of a :class:`~impactnet.models.scenes.Scene`, by name (a box
    body a box, a compound body its parts)."""
    bodies = scene.bodies.values() if isinstance(scene.bodies, dict) else scene.bodies
    return {str(b.name): Shape(b.parts, str(b.name)) if b.parts is not None
            else Shape.box(b.size, str(b.name), transient=False) for b in bodies}
