"""One pair's request (POST /v2/contact) as the dispatcher's
:class:`~impactnet.models.dispatch.Pairs`: a body is a scene object (the scene's shape), a raw
``size`` (a box) or inline ``parts`` (a compound body built for this request within the settings'
limits); its orientation becomes a unit quaternion. Shared with the batch and frame codecs:
:func:`quaternion_of`, :func:`unknown_object_reason`, :func:`rotation_reason`.
"""
from __future__ import annotations

import math
import re
import warnings
from dataclasses import replace

import numpy as np

from impactnet.models.compound.body_table import TransientParts
from impactnet.models.compound.meshes import HullWarning
from impactnet.models.compound.part_limits import LimitExceeded, PartLimits, check_counts
from impactnet.models.compound.scene_parts import compound_parts
from impactnet.models.dispatch import Pairs, Shape
from impactnet.models.geometry.rotations import (
    QUATERNION_MIN_NORM,
    InvalidRotationError,
    rotation_to_quaternion,
)
from impactnet.models.scene_fields import SceneError
from impactnet.service.codecs.requests import OBJECT_NAME_MAX, Body, ContactRequest
from impactnet.service.errors import InputError, LimitRefused
from impactnet.service.scene import SceneView

_ROWS_SUFFIX = re.compile(r" at rows \[.*$")
#: Hull corners whose square costs about one box-pair solve to build a hull of (Qhull and
#: the face and edge tables: a 512-corner frustum takes ~0.1 s, ~4,000 box-pair solves).
CORNERS_SQUARED_PER_UNIT = 64


def rotation_reason(exc: InvalidRotationError) -> str:
    """The reason of a rotation error without its "invalid <field>: " prefix and row list."""
    text = str(exc)
    prefix = f"invalid {exc.field}: "
    text = text[len(prefix):] if text.startswith(prefix) else text
    return _ROWS_SUFFIX.sub("", text)


def unknown_object_reason(names, scene: SceneView) -> str:
    """Why object ``names`` cannot be used: no scene, or the scene's bodies (all named)."""
    if scene.name is None:
        return "no scene is loaded, so objects cannot be named; give `size` instead"
    shown = ", ".join(repr(str(n)) for n in list(names)[:5])
    bodies = sorted(set(scene.object_names) | set(scene.compound_names))
    return f"unknown object {shown}; scene {scene.name!r} has: {', '.join(bodies)}"


def euler_quaternion(euler: list[float], convention: str) -> list[float]:
    """Unit quaternion (canonical w >= 0) of one Euler triple, in plain floats (the closed
    form of :func:`impactnet.models.geometry.rotations.euler_to_quaternion`, tested equal).
    zyx: q = qz(yaw) qy(pitch) qx(roll); xyz: q = qx(a) qy(b) qz(c)."""
    c0, s0 = math.cos(0.5 * euler[0]), math.sin(0.5 * euler[0])
    c1, s1 = math.cos(0.5 * euler[1]), math.sin(0.5 * euler[1])
    c2, s2 = math.cos(0.5 * euler[2]), math.sin(0.5 * euler[2])
    if convention == "zyx":
        q = [c2 * c1 * c0 + s2 * s1 * s0, c2 * c1 * s0 - s2 * s1 * c0,
             c2 * s1 * c0 + s2 * c1 * s0, s2 * c1 * c0 - c2 * s1 * s0]
    else:
        q = [c0 * c1 * c2 - s0 * s1 * s2, s0 * c1 * c2 + c0 * s1 * s2,
             c0 * s1 * c2 - s0 * c1 * s2, c0 * c1 * s2 + s0 * s1 * c2]
    return [-v for v in q] if q[0] < 0.0 else q


def quaternion_of(body: Body, field: str, convention: str) -> list[float]:
    """The unit quaternion of a request body's one orientation (422 naming the field,
    ``field`` being the body's path: ``a``, ``bodies[3]``, if it is not a rotation)."""
    q = body.quaternion
    if q is not None:  # plain floats: a single pair avoids NumPy's per-call cost
        norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        if norm < QUATERNION_MIN_NORM:
            raise InputError(f"{field}.quaternion", f"norm below {QUATERNION_MIN_NORM:g}: "
                             "not a rotation", type_="zero_quaternion")
        return [v / norm for v in q]
    if body.euler is not None:  # finite and bounded (schema): always a rotation
        return euler_quaternion(body.euler, convention)
    try:
        return rotation_to_quaternion(matrix=body.matrix)[0].tolist()
    except InvalidRotationError as exc:
        raise InputError(f"{field}.matrix", rotation_reason(exc), type_="invalid_rotation") \
            from exc


def part_limits(settings) -> PartLimits:
    """The limits of inline parts (settings of the same names); no mesh files."""
    return PartLimits(max_parts=settings.max_inline_parts,
                      max_frustum_sides=settings.max_frustum_sides,
                      max_hull_points=settings.max_hull_points,
                      max_section_points=settings.max_section_points,
                      max_mesh_bytes=settings.max_mesh_bytes,
                      max_mesh_vertices=settings.max_mesh_vertices,
                      max_mesh_faces=settings.max_mesh_faces,
                      max_vertices=settings.max_inline_vertices,
                      max_name_chars=OBJECT_NAME_MAX, mesh_folder=None)


def inline_cost(bodies, limits: PartLimits) -> float:
    """The cost (box-pair solves) of building the inline parts of ``bodies`` ((field, Body)
    pairs), from their tables as given; counts past a limit are 413 here already."""
    cost = 0.0
    for field, body in bodies:
        if body.parts is None:
            continue
        try:
            corners = check_counts(body.parts, f"{field}.parts", limits, "request")
        except LimitExceeded as exc:
            raise LimitRefused("geometry_too_large", exc.path, exc.reason, exc.limit) \
                from None
        cost += corners * corners / CORNERS_SQUARED_PER_UNIT
    return cost


def inline_shape(body: Body, field: str, limits: PartLimits, notes: list[str]) -> Shape:
    """A body given by ``parts``, built within ``limits`` (413 past one, 422 for a bad part
    naming its field); a mesh replaced by its hull adds a note."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", HullWarning)
        try:
            parts = compound_parts({"parts": body.parts}, field, "request", limits)
        except LimitExceeded as exc:
            raise LimitRefused("geometry_too_large", exc.path, exc.reason, exc.limit) from None
        except SceneError as exc:
            raise InputError(exc.path, exc.reason, type_="invalid_part") from None
    notes += [str(w.message).removeprefix("request: ") for w in caught]
    return Shape(TransientParts(parts))


def body_shape(body: Body, field: str, scene: SceneView, limits: PartLimits,
               notes: list[str]) -> Shape:
    """The shape of one request body: its scene object's, a raw size's or inline parts'."""
    if body.parts is not None:
        return inline_shape(body, field, limits, notes)
    if body.object is not None:
        index = scene.with_compound.index_of(body.object)
        if index < 0:
            raise InputError(f"{field}.object", unknown_object_reason([body.object], scene),
                             type_="unknown_object")
        return scene.shapes[index]
    return Shape.box(body.size)


def request_pairs(request: ContactRequest, scene: SceneView,
                  limits: PartLimits) -> tuple[Pairs, list[str]]:
    """The one pair of a request, and its notes (meshes replaced by their hull). B's inline
    parts get what A's left of the request's corners (``max_vertices``)."""
    notes: list[str] = []
    shapes, poses = [], []
    for field, body in (("a", request.a), ("b", request.b)):
        shape = body_shape(body, field, scene, limits, notes)
        shapes.append(shape)
        poses += [np.array([body.position], np.float64),
                  np.array([quaternion_of(body, field, request.euler_convention)])]
        if body.parts is not None and limits.max_vertices is not None:
            used = sum(len(p.vertices()) for p in shape.parts)
            limits = replace(limits, max_vertices=max(0, limits.max_vertices - used))
    pairs = Pairs(tuple(shapes), np.array([0]), np.array([1]), *poses)
    return pairs, notes
