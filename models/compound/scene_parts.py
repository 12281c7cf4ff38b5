"""Compound bodies in scene files: a body table given by a generator or by a list of parts.

::

    [bodies.container40]          # a generator and its parameters
    generator = "container"       # container | spreader | cell_guide
    kind = "40ft"                 # container, spreader: 20ft | 40ft | 40ft_hc
    detail = 2                    # container: 1 solid castings, 2 apertures
    # sides = 32                  # spreader: sides of a twistlock head's section, 8-256
    # entry_angle_deg = 30.0      # cell_guide: lean of the entry guide from the vertical

    [[bodies.stop.parts]]         # or explicit parts, in the body's frame (metres)
    name = "block"
    box = { size = [0.2, 0.2, 0.1], centre = [0.0, 0.0, 0.05] }
    [[bodies.stop.parts]]
    name = "ramp"
    points = [[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.1]]  # the hull of the points
    [[bodies.stop.parts]]
    name = "cone"
    frustum = { sides = 16, base = [0.1, 0.06], tip_scale = 0.5, height = 0.05,
                centre = [0, 0, 0.1] }                  # a stadium frustum, base at centre
    [[bodies.stop.parts]]
    name = "lid"
    mesh = "lid.stl"              # STL/OBJ/GLB next to the scene file: its convex hull

Every part goes through :func:`impactnet.models.compound.parts.validate_parts`; its errors
come back as :class:`SceneError` naming the field (``bodies.stop.parts[2].mesh: ...``).
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from impactnet.models import scene_fields as sf
from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound.parts import BoxPart, ConvexPart, PartError, validate_parts
from impactnet.models.scene_fields import SceneError

#: Generators and the parameters each takes (all optional, the generator's defaults apply).
GENERATORS = {"container": ("kind", "detail"), "spreader": ("kind", "sides"),
              "cell_guide": ("entry_angle_deg",)}
#: Keys of a body table that describe a compound body.
COMPOUND_KEYS = {"generator", "parts", *(k for keys in GENERATORS.values() for k in keys)}
#: The shapes a part may take (exactly one per part).
SHAPES = ("box", "points", "frustum", "mesh")


def is_compound(entry: Mapping) -> bool:
    """Whether a body table describes a compound body."""
    return bool(COMPOUND_KEYS & set(entry))


def compound_parts(entry: Mapping, path: str, source: str) -> tuple:
    """The validated parts of a compound body table ``entry`` at ``path`` (``bodies.X``)."""
    if ("generator" in entry) == ("parts" in entry):
        raise SceneError(source, path, "give exactly one of `generator` and `parts`")
    try:
        if "generator" in entry:
            return _generated(entry, path, source)
        parts = entry["parts"]
        if not isinstance(parts, list) or not parts:
            raise SceneError(source, f"{path}.parts", "expected at least one [[parts]] entry")
        return validate_parts(path, [_part(p, f"{path}.parts[{k}]", source)
                                     for k, p in enumerate(parts)])
    except PartError as exc:
        names = [p.get("name") for p in entry.get("parts", []) if isinstance(p, Mapping)]
        where = f"{path}.parts[{names.index(exc.part)}]" if exc.part in names else path
        raise SceneError(source, where, str(exc)) from None


def _generated(entry: Mapping, path: str, source: str) -> tuple:
    generator = entry["generator"]
    if generator not in GENERATORS:
        raise SceneError(source, f"{path}.generator", f"unknown generator {generator!r}; "
                         f"choose one of {sorted(GENERATORS)}")
    extra = sorted(set(entry) & COMPOUND_KEYS - {"generator", *GENERATORS[generator]})
    if extra:
        raise SceneError(source, path, f"{', '.join(extra)} do not apply to generator "
                         f"{generator!r} (it takes {', '.join(GENERATORS[generator])})")
    params = {k: entry[k] for k in GENERATORS[generator] if k in entry}
    try:
        return getattr(cb, generator)(**params)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, PartError):
            raise
        raise SceneError(source, path, str(exc)) from None


def _vector(value, path: str, source: str, width: int = 3) -> list[float]:
    if not isinstance(value, list) or len(value) != width:
        raise SceneError(source, path, f"expected {width} numbers, got {value!r}")
    return [sf.number(v, f"{path}[{i}]", source) for i, v in enumerate(value)]


def _part(entry, path: str, source: str):
    entry = sf.table(entry, path, ({"name"}, set(SHAPES)), source)
    name = sf.name(entry["name"], f"{path}.name", source)
    shapes = [s for s in SHAPES if s in entry]
    if len(shapes) != 1:
        raise SceneError(source, path, f"give exactly one shape of {', '.join(SHAPES)}")
    shape, value = shapes[0], entry[shapes[0]]
    where = f"{path}.{shape}"
    if shape == "box":
        value = sf.table(value, where, ({"size"}, {"centre"}), source)
        size = tuple(sf.positive(v, f"{where}.size[{i}]", source)
                     for i, v in enumerate(_vector(value["size"], f"{where}.size", source)))
        return BoxPart(name, size, tuple(_vector(value.get("centre", [0.0] * 3),
                                                 f"{where}.centre", source)))
    if shape == "points":
        if not isinstance(value, list) or len(value) < 4:
            raise SceneError(source, where, "expected at least 4 points [x, y, z]")
        return ConvexPart(name, tuple(tuple(_vector(p, f"{where}[{k}]", source))
                                      for k, p in enumerate(value)))
    if shape == "frustum":
        return _frustum(name, value, where, source)
    from impactnet.models.compound.meshes import inline_mesh_part, mesh_part

    if isinstance(value, Mapping):  # inline in a request: {format, data (base64)}
        return inline_mesh_part(name, dict(value), where, source)
    return mesh_part(name, Path(source).parent / sf.text(value, where, source), where, source)


def _frustum(name: str, value, where: str, source: str) -> ConvexPart:
    """A stadium frustum: ``base`` [along, across] (m) at ``centre``, narrowing by
    ``tip_scale`` over ``height`` (m, signed: negative points down), ``sides`` vertices."""
    value = sf.table(value, where, ({"sides", "base", "height"}, {"tip_scale", "centre"}),
                     source)
    sides = value["sides"]
    if isinstance(sides, bool) or not isinstance(sides, int):
        raise SceneError(source, f"{where}.sides", f"expected an even integer, got {sides!r}")
    along, across = (sf.positive(v, f"{where}.base[{i}]", source)
                     for i, v in enumerate(_vector(value["base"], f"{where}.base", source, 2)))
    scale = sf.positive(value.get("tip_scale", 1.0), f"{where}.tip_scale", source)
    height = sf.number(value["height"], f"{where}.height", source)
    x, y, z = _vector(value.get("centre", [0.0] * 3), f"{where}.centre", source)
    try:
        section = cb.stadium(along, across, sides)
    except ValueError as exc:
        raise SceneError(source, f"{where}.sides", str(exc)) from None
    points = [(x + u, y + w, z) for u, w in section]
    points += [(x + scale * u, y + scale * w, z + height) for u, w in section]
    return ConvexPart(name, tuple(points))


def parts_geometry(parts) -> list:
    """The parts as plain lists for the scene hash: name, kind and vertices (m)."""
    return [[p.name, type(p).__name__, np.asarray(p.vertices(), float).round(12).tolist()]
            for p in parts]
