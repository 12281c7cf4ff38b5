"""The bodies of a scene, a box (``size``) or a compound body made of parts (issue #20), and
the pairs of bodies that can collide.

A body table of a scene file is either a box::

    [bodies.container40]
    size = [12.192, 2.438, 2.591]  # full edge lengths [lx, ly, lz], metres, > 0

or a compound body, given by a generator with its parameters or by an explicit list of parts
(the format is in :mod:`impactnet.models.compound.scene_parts`)::

    [bodies.spreader]
    generator = "spreader"
    kind = "40ft"
    sides = 32

A compound body's ``size`` is the extent of its parts' bounds (its envelope), so that code that
reads sizes gets a sensible box around it; code that solves contacts must not take it for the
body (:meth:`impactnet.models.scenes.Scene.pair_sizes` refuses compound pairs).

Point tolerances of compound pairs (issue #21) use the smallest extent of the bounding box of
the touching *part*, where a part is a group of generated pieces: a generator names the convex
pieces of one physical part ``group/piece`` (a detail-2 top casting's aperture pieces are
``casting_top_fl/ring_0``, ...), and the group's bounds are the union of its pieces' (the
casting's 178 x 162 x 118 mm at every detail level, never the edge of one piece or of one side
of a many-sided frustum). See :meth:`Body.touching_extent`.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from impactnet.models import scene_fields as sf
from impactnet.models.compound.parts import Part, bounds
from impactnet.models.compound.scene_parts import COMPOUND_KEYS, compound_parts, is_compound
from impactnet.models.scene_fields import SceneError

#: Keys of a body table: a box takes ``size``, a compound body the generator's or ``parts``.
BODY_KEYS = (set(), {"size", "description", *COMPOUND_KEYS})
#: Keys of a ``[[pairs]]`` entry.
PAIR_KEYS = ({"a", "b"}, {"description"})
#: Separates a part's group from its piece in generated part names (``casting_top_fl/ring_0``).
GROUP_SEPARATOR = "/"


def part_group(part_name: str) -> str:
    """The group a part belongs to: the name before :data:`GROUP_SEPARATOR` (or the name)."""
    return part_name.split(GROUP_SEPARATOR, 1)[0]


def group_extents(parts) -> dict[str, np.ndarray]:
    """Per part group (:func:`part_group`), the extent (3,) of the union of its pieces'
    bounds, metres, in the parts' order."""
    lows: dict[str, np.ndarray] = {}
    highs: dict[str, np.ndarray] = {}
    for part in parts:
        lo, hi = bounds(part)
        group = part_group(part.name)
        lows[group] = np.minimum(lows.get(group, lo), lo)
        highs[group] = np.maximum(highs.get(group, hi), hi)
    return {g: highs[g] - lows[g] for g in lows}


@dataclass(frozen=True)
class Body:
    """A body of a scene: a box, or a compound body made of parts."""

    name: str  # identifier, unique in the scene
    size: tuple[float, float, float]  # full edge lengths (lx, ly, lz), metres, > 0; for a
    # compound body the extent of its parts' bounds (its envelope)
    description: str = ""  # free text, not part of the scene hash
    parts: tuple[Part, ...] | None = None  # compound body: its validated parts (body frame);
    # None: a box
    spec: Mapping | None = field(default=None, compare=False)  # compound: the file's table

    @property
    def is_compound(self) -> bool:
        """Whether the body is made of parts (:mod:`impactnet.models.compound`)."""
        return self.parts is not None

    @cached_property
    def _smallest_extents(self) -> dict[str, float]:
        """Part group -> the smallest extent of its bounds (m); a box: its own name."""
        if not self.is_compound:
            return {self.name: float(min(self.size))}
        return {g: float(e.min()) for g, e in group_extents(self.parts).items()}

    def touching_extent(self, part: str | None = None) -> float:
        """The smallest extent (m) of the bounding box of ``part``'s group (module docstring);
        ``None``: the smallest over the body's groups (the tightest this body can ask for). A
        box: its shortest edge, whatever ``part`` names."""
        extents = self._smallest_extents
        if part is None or not self.is_compound:
            return min(extents.values())
        group = part_group(part)
        if group not in extents:
            raise KeyError(f"body {self.name!r} has no part {part!r} (groups: "
                           f"{', '.join(extents)})")
        return extents[group]


@dataclass(frozen=True)
class BodyPair:
    """Two bodies (names) that can collide; A is the first, the normal points from A to B."""

    a: str  # name of body A
    b: str  # name of body B (may equal a)
    description: str = ""  # why the pair is in the scene; not part of the scene hash

    @property
    def key(self) -> str:
        """``"a/b"``: a readable, unique name of the pair."""
        return f"{self.a}/{self.b}"


def parse_bodies(table, source: str) -> tuple[Body, ...]:
    """The bodies of a scene's ``[bodies]`` table, in file order; raises :class:`SceneError`
    naming the field."""
    if not isinstance(table, Mapping) or not table:
        raise SceneError(source, "bodies", "expected at least one [bodies.NAME] table")
    bodies = []
    for key, entry in table.items():
        path = f"bodies.{key}"
        name = sf.name(key, path, source)
        entry = sf.table(entry, path, BODY_KEYS, source)
        description = sf.text(entry.get("description", ""), f"{path}.description", source)
        if is_compound(entry):
            bodies.append(_compound_body(name, entry, description, path, source))
        else:
            bodies.append(Body(name, _box_size(entry, path, source), description))
    return tuple(bodies)


def _compound_body(name: str, entry: Mapping, description: str, path: str,
                   source: str) -> Body:
    if "size" in entry:
        raise SceneError(source, path, "a compound body takes no `size` (its parts give it)")
    parts = compound_parts(entry, path, source)
    lows, highs = zip(*(bounds(p) for p in parts))
    extent = tuple(float(v) for v in np.max(highs, axis=0) - np.min(lows, axis=0))
    spec = {k: v for k, v in entry.items() if k != "description"}
    return Body(name, extent, description, parts, spec)


def _box_size(entry: Mapping, path: str, source: str) -> tuple[float, float, float]:
    if "size" not in entry:
        raise SceneError(source, path, f"missing {path}.size (or, for a compound body, "
                         "`generator` or `parts`)")
    size = entry["size"]
    if not isinstance(size, list | tuple) or len(size) != 3:
        raise SceneError(source, f"{path}.size",
                         f"expected 3 numbers [lx, ly, lz] in metres, got {size!r}")
    return tuple(sf.positive(v, f"{path}.size[{i}]", source) for i, v in enumerate(size))


def parse_pairs(entries, names: set[str], source: str) -> tuple[BodyPair, ...]:
    """The ``[[pairs]]`` entries of a scene, in file order, against the body ``names``; raises
    :class:`SceneError` naming the field (unknown body, a pair given twice, also as (b, a))."""
    if not isinstance(entries, list) or not entries:
        raise SceneError(source, "pairs", "expected at least one [[pairs]] entry")
    pairs, seen = [], {}
    for k, entry in enumerate(entries):
        path = f"pairs[{k}]"
        entry = sf.table(entry, path, PAIR_KEYS, source)
        a, b = (sf.text(entry[s], f"{path}.{s}", source) for s in "ab")
        for side, body in (("a", a), ("b", b)):
            if body not in names:
                raise SceneError(source, f"{path}.{side}", f"unknown body {body!r} "
                                 f"(bodies: {', '.join(sorted(names))})")
        unordered = frozenset((a, b))
        if unordered in seen:
            raise SceneError(source, path, f"duplicate pair ({a}, {b}): already given as "
                             f"pairs[{seen[unordered]}]")
        seen[unordered] = k
        pairs.append(BodyPair(a, b, sf.text(entry.get("description", ""),
                                          f"{path}.description", source)))
    return tuple(pairs)
