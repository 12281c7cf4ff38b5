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
    name = "pin"
    frustum = { sides = 12, base = 0.05, height = 0.08 } # base = d: a regular 12-gon cone
    [[bodies.stop.parts]]
    name = "chamfer"
    wedge = { size = [0.1, 0.2, 0.05], centre = [0.15, 0, 0.025], high = "-x",
              low_height = 0.0 }  # a box whose top slopes from full height at -x to 0 at +x
    [[bodies.stop.parts]]
    name = "rail"
    prism = { section = [[0, 0], [0.04, 0], [0.02, 0.03]], height = 1.0, axis = "x",
              centre = [0, 0, 0.1] }  # a convex polygon (in order) extruded along an axis
    [[bodies.stop.parts]]
    name = "lid"
    mesh = "lid.stl"              # STL/OBJ/GLB in the scene file's folder: its convex hull

The generated shapes' parameters are documented in :mod:`impactnet.models.compound.shapes`
(``centre`` defaults to the origin; ``tip_scale`` to 1, ``high`` to ``"-x"``, ``low_height`` to 0,
``axis`` to ``"z"``). Every part goes through :func:`impactnet.models.compound.parts.validate_parts`
(domain, flat hulls, a part inside a box part) and :func:`check_not_inside_convex` (a part inside a
convex part); their errors come back as :class:`SceneError` naming the field
(``bodies.stop.parts[2].mesh: ...``).

Parts given by a client (the HTTP API) come with
:class:`~impactnet.models.compound.part_limits.PartLimits`: their counts are checked on the tables
before any shape is built, and a mesh must be data (``{format, data}``), never a file name. A scene
file may name mesh files in its own folder only.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from impactnet.models import scene_fields as sf
from impactnet.models.compound import crane_bodies as cb
from impactnet.models.compound import shapes
from impactnet.models.compound.part_limits import PartLimits, check_counts, mesh_file
from impactnet.models.compound.parts import (
    INSIDE_TOL_REL,
    BoxPart,
    ConvexPart,
    PartError,
    bounds,
    validate_parts,
)
from impactnet.models.scene_fields import SceneError

#: Generators and the parameters each takes (all optional, the generator's defaults apply).
GENERATORS = {"container": ("kind", "detail"), "spreader": ("kind", "sides"),
              "cell_guide": ("entry_angle_deg",)}
#: Keys of a body table that describe a compound body.
COMPOUND_KEYS = {"generator", "parts", *(k for keys in GENERATORS.values() for k in keys)}
#: A shape parameter's field as a generator names it first in a message (``section[2]``).
_PARAMETER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\[\d+\])*")
#: The shapes a part may take (exactly one per part).
SHAPES = ("box", "points", "frustum", "wedge", "prism", "mesh")


def is_compound(entry: Mapping) -> bool:
    """Whether a body table describes a compound body."""
    return bool(COMPOUND_KEYS & set(entry))


def compound_parts(entry: Mapping, path: str, source: str,
                   limits: PartLimits | None = None) -> tuple:
    """The validated parts of a compound body table ``entry`` at ``path`` (``bodies.X``).

    ``limits`` bound the parts' counts (checked before any shape is built) and say where mesh
    files may be read from; None: a scene file's (no bounds, meshes in ``source``'s folder).
    """
    if limits is None:
        limits = PartLimits(mesh_folder=Path(source).parent)
    if ("generator" in entry) == ("parts" in entry):
        raise SceneError(source, path, "give exactly one of `generator` and `parts`")
    try:
        if "generator" in entry:
            return check_not_inside_convex(path, _generated(entry, path, source))
        parts = entry["parts"]
        if not isinstance(parts, list) or not parts:
            raise SceneError(source, f"{path}.parts", "expected at least one [[parts]] entry")
        check_counts(parts, f"{path}.parts", limits, source)
        return check_not_inside_convex(path, validate_parts(
            path, [_part(p, f"{path}.parts[{k}]", source, limits)
                   for k, p in enumerate(parts)]))
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


def _part(entry, path: str, source: str, limits: PartLimits):
    entry = sf.table(entry, path, ({"name"}, set(SHAPES)), source)
    name = sf.name(entry["name"], f"{path}.name", source)
    shapes_given = [s for s in SHAPES if s in entry]
    if len(shapes_given) != 1:
        raise SceneError(source, path, f"give exactly one shape of {', '.join(SHAPES)}")
    shape, value = shapes_given[0], entry[shapes_given[0]]
    where = f"{path}.{shape}"
    if shape == "box":
        value = sf.table(value, where, ({"size"}, {"centre"}), source)
        return BoxPart(name, _sizes(value["size"], f"{where}.size", source),
                       _centre(value, where, source))
    if shape == "points":
        if not isinstance(value, list) or len(value) < 4:
            raise SceneError(source, where, "expected at least 4 points [x, y, z]")
        return ConvexPart(name, tuple(tuple(_vector(p, f"{where}[{k}]", source))
                                      for k, p in enumerate(value)))
    if shape in _GENERATED:
        try:
            points = _GENERATED[shape](value, where, source)
        except ValueError as exc:
            if isinstance(exc, SceneError):
                raise
            raise _shape_error(exc, where, source) from None
        return ConvexPart(name, tuple(map(tuple, np.asarray(points, np.float64))))
    from impactnet.models.compound.meshes import inline_mesh_part, mesh_part

    if isinstance(value, Mapping):  # inline in a request: {format, data (base64)}
        return inline_mesh_part(name, dict(value), where, source, limits)
    return mesh_part(name, mesh_file(sf.text(value, where, source), limits, where, source),
                     where, source)


def _shape_error(exc: ValueError, where: str, source: str) -> SceneError:
    """A shape generator's ``"parameter: reason"`` as a SceneError on that parameter's field;
    a message without a parameter name goes on the shape's field."""
    field, sep, reason = str(exc).partition(": ")
    if sep and _PARAMETER.fullmatch(field):
        return SceneError(source, f"{where}.{field}", reason)
    return SceneError(source, where, str(exc))


def _sizes(value, where: str, source: str, width: int = 3) -> tuple[float, ...]:
    return tuple(sf.positive(v, f"{where}[{i}]", source)
                 for i, v in enumerate(_vector(value, where, source, width)))


def _centre(value: Mapping, where: str, source: str) -> tuple[float, ...]:
    return tuple(_vector(value.get("centre", [0.0] * 3), f"{where}.centre", source))


def _integer(value, where: str, source: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(source, where, f"expected an integer, got {value!r}")
    return value


def _frustum(value, where: str, source: str) -> np.ndarray:
    """:func:`impactnet.models.compound.shapes.frustum_points` of a ``frustum`` table."""
    value = sf.table(value, where, ({"sides", "base", "height"}, {"tip_scale", "centre"}),
                     source)
    sides = _integer(value["sides"], f"{where}.sides", source)
    base = value["base"]  # a diameter (regular polygon) or [along, across] (stadium)
    base = (_sizes(base, f"{where}.base", source, 2) if isinstance(base, list)
            else sf.positive(base, f"{where}.base", source))
    scale = sf.positive(value.get("tip_scale", 1.0), f"{where}.tip_scale", source)
    height = sf.number(value["height"], f"{where}.height", source)
    return shapes.frustum_points(base, sides, height, scale, _centre(value, where, source))


def _wedge(value, where: str, source: str) -> np.ndarray:
    """:func:`impactnet.models.compound.shapes.wedge_points` of a ``wedge`` table."""
    value = sf.table(value, where, ({"size"}, {"centre", "high", "low_height"}), source)
    return shapes.wedge_points(_sizes(value["size"], f"{where}.size", source),
                               _centre(value, where, source),
                               sf.text(value.get("high", "-x"), f"{where}.high", source),
                               sf.number(value.get("low_height", 0.0), f"{where}.low_height",
                                         source))


def _prism(value, where: str, source: str) -> np.ndarray:
    """:func:`impactnet.models.compound.shapes.prism_points` of a ``prism`` table."""
    value = sf.table(value, where, ({"section", "height"}, {"axis", "centre"}), source)
    section = value["section"]
    if not isinstance(section, list) or len(section) < 3:
        raise SceneError(source, f"{where}.section", "expected at least 3 points [u, v]")
    section = [_vector(p, f"{where}.section[{k}]", source, 2) for k, p in enumerate(section)]
    return shapes.prism_points(section, sf.number(value["height"], f"{where}.height", source),
                               sf.text(value.get("axis", "z"), f"{where}.axis", source),
                               _centre(value, where, source))


#: Parsers of the generated shapes: (table, field path, source) -> points (k, 3).
_GENERATED = {"frustum": _frustum, "wedge": _wedge, "prism": _prism}


def check_not_inside_convex(body: str, parts: tuple) -> tuple:
    """``parts`` unchanged, after refusing (:class:`PartError`) a part whose every vertex lies
    in a convex part of the same body (within
    :data:`~impactnet.models.compound.parts.INSIDE_TOL_REL` of that part's size): it can never touch
    anything. The box containers are :func:`~impactnet.models.compound.parts.validate_parts`' test.
    Only the parts whose bounds
    lie in a convex part's bounds are tested against its hull (Qhull's facets)."""
    lows, highs = (np.array(b) for b in zip(*(bounds(p) for p in parts)))
    for i, outer in enumerate(parts):
        if not isinstance(outer, ConvexPart):
            continue
        slack = INSIDE_TOL_REL * float((highs[i] - lows[i]).max())
        within = ((lows >= lows[i] - slack) & (highs <= highs[i] + slack)).all(axis=1)
        within[i] = False
        if not within.any():
            continue
        from scipy.spatial import ConvexHull

        facets = ConvexHull(outer.vertices()).equations  # n . x + d <= 0 inside
        for k in np.flatnonzero(within):
            inner = parts[k].vertices()
            if (inner @ facets[:, :3].T + facets[:, 3]).max() <= slack:
                raise PartError(parts[k].name, f"lies wholly inside part {outer.name!r} of "
                                               f"body {body!r}: it can never touch anything")
    return parts


def parts_geometry(parts) -> list:
    """The parts as plain lists for the scene hash: name, kind and vertices (m)."""
    return [[p.name, type(p).__name__, np.asarray(p.vertices(), float).round(12).tolist()]
            for p in parts]
