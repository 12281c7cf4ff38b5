"""Bodies as the dispatcher sees them: a :class:`Shape` (a box, or a compound body's parts) and
the :class:`Pairs` of N poses that name two shapes each.

A box is a body of one part named ``box``; a scene object keeps its scene name, a raw size or a
client's inline parts have none. Features are named for every part: a box part's by the box's
fixed ids (``face +z``, ``edge x(+y,-z)``, ``vertex (+,-,+)``), a convex part's by its hull's
ids (``face 3``, ``edge 17``, ``vertex 40``: faces first, then edges, then vertices).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from impactnet.models.compound.body_table import TransientParts, body_table
from impactnet.models.compound.parts import BoxPart
from impactnet.models.geometry import box_features as bf

#: The name of a box body's one part.
BOX_PART = "box"
#: (name, kind) of every box feature id (named once, at import).
BOX_FEATURES = tuple((str(bf.feature_name(i)), str(bf.feature_kind(i)))
                     for i in range(bf.N_FEATURES))


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

    @cached_property
    def _feature_names(self) -> dict:
        return {}  # (part, feature id) -> (name, kind): each named once per shape

    def feature(self, part: int, feature: int) -> tuple[str, str]:
        """(name, kind) of a feature id of part ``part``: kind face, edge, vertex or none."""
        found = self._feature_names.get((part, feature))
        if found is None:
            found = self._feature_names[(part, feature)] = self._named(part, feature)
        return found

    def _named(self, part: int, feature: int) -> tuple[str, str]:
        if feature < 0:
            return "none", "none"
        if isinstance(self.parts[part], BoxPart):
            return BOX_FEATURES[feature]
        hull = body_table(self.parts).hulls[part]
        faces, edges = hull.n_faces, hull.n_edges
        if feature < faces:
            return f"face {feature}", "face"
        if feature < faces + edges:
            return f"edge {feature - faces}", "edge"
        return f"vertex {feature - faces - edges}", "vertex"


class Shapes(Sequence):
    """The shapes of a batch: named shapes (a scene's objects, inline bodies), then k boxes
    given by their sizes (k, 3), m, each made a :class:`Shape` only when asked for (a batch of
    100,000 distinct box sizes makes no Python object a size: :class:`ShapeTable` reads the
    sizes as a column)."""

    def __init__(self, named: tuple[Shape, ...], box_sizes: np.ndarray | None = None) -> None:
        self.named = tuple(named)
        self.box_sizes = np.zeros((0, 3)) if box_sizes is None else \
            np.asarray(box_sizes, np.float64).reshape(-1, 3)
        self._made: dict[int, Shape] = {}

    def __len__(self) -> int:
        return len(self.named) + len(self.box_sizes)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return tuple(self[i] for i in range(*k.indices(len(self))))
        k = range(len(self))[k]  # negative indices, IndexError
        if k < len(self.named):
            return self.named[k]
        if k not in self._made:
            self._made[k] = Shape.box(self.box_sizes[k - len(self.named)])
        return self._made[k]


class ShapeTable:
    """What the dispatcher reads of every shape of a :class:`Pairs`, as columns (s shapes), so
    that a batch of many distinct box sizes is planned with array operations, not shape by
    shape. The bounding spheres are computed when first read (a compound shape's builds its
    body table: never on the event loop, where a single pair is only asked whether it is two
    boxes)."""

    def __init__(self, shapes) -> None:
        self.shapes = shapes  # a tuple, or Shapes (its box sizes read as a column)
        named = tuple(shapes.named) if isinstance(shapes, Shapes) else tuple(shapes)
        box = [s.is_box for s in named]
        size = np.array([s.parts[0].size if b else (1.0, 1.0, 1.0) for s, b in zip(named, box)],
                        np.float64).reshape(len(named), 3)
        self.is_box = np.array(box, bool)  # (s,) bool: a box
        self.size = size  # (s, 3) a box's edge lengths, m; else 1
        self.parts = np.array([len(s.parts) for s in named], np.int64)  # (s,) parts
        if isinstance(shapes, Shapes) and len(shapes.box_sizes):  # raw sizes: boxes, after
            sizes = shapes.box_sizes
            self.is_box = np.concatenate([self.is_box, np.ones(len(sizes), bool)])
            self.size = np.concatenate([size, sizes])
            self.parts = np.concatenate([self.parts, np.ones(len(sizes), np.int64)])

    @cached_property
    def spheres(self) -> tuple[np.ndarray, np.ndarray]:
        """(centres (s, 3) in the body frames, radii (s,)), m: a box's from its size (no table
        built), another shape's from its :attr:`Shape.sphere`."""
        centre = np.zeros((len(self.is_box), 3))
        radius = np.linalg.norm(0.5 * self.size, axis=1)
        for k in np.flatnonzero(~self.is_box).tolist():
            centre[k], radius[k] = self.shapes[k].sphere
        return centre, radius


@dataclass(frozen=True)
class Pairs:
    """N poses of pairs of shapes (world frame, metres, unit quaternions [w, x, y, z]); every
    column has n rows or one (broadcast)."""

    shapes: Sequence[Shape]  # the shapes the rows name (a tuple, or Shapes)
    shape_a: np.ndarray  # (n,) int64 index into shapes
    shape_b: np.ndarray
    position_a: np.ndarray  # (n, 3)
    quaternion_a: np.ndarray  # (n, 4)
    position_b: np.ndarray
    quaternion_b: np.ndarray

    def __len__(self) -> int:
        return self.n

    @cached_property
    def n(self) -> int:
        """The rows (the longest column)."""
        return max(len(c) for c in (self.shape_a, self.shape_b, self.position_a,
                                    self.quaternion_a, self.position_b, self.quaternion_b))

    @cached_property
    def _columns(self) -> dict:
        return {}

    @cached_property
    def table(self) -> ShapeTable:
        """The columns of :attr:`shapes` (:class:`ShapeTable`), built once."""
        return ShapeTable(self.shapes)

    def column(self, name: str) -> np.ndarray:
        """Column ``name`` with n rows: the column itself where it has them, else broadcast (a
        read-only view, made once). Read, never written."""
        values = getattr(self, name)
        if len(values) == self.n:
            return values
        found = self._columns.get(name)
        if found is None:
            found = self._columns[name] = np.broadcast_to(values, (self.n,) + values.shape[1:])
        return found

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
