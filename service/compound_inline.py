"""A single pair (POST /v1/contact) with a compound body given inline: ``parts`` in the scene
files' format (:mod:`impactnet.models.compound.scene_parts`; a mesh as ``{format, data}``
base64, never a file name).

The parts' counts are checked against the settings' limits before any shape is built
(:func:`part_limits`; 413 ``geometry_too_large`` naming the field and the limit); bad parts are
422 naming the field (``a.parts[2].mesh.data``): an unknown shape or key, a mesh that does not
load, a flat hull, a part inside another. The other body may be a scene object (box or
compound) or a raw size. Runs in a worker thread (:mod:`impactnet.service.limits.lanes`).
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from impactnet.models.compound.body_table import TransientParts
from impactnet.models.compound.meshes import HullWarning
from impactnet.models.compound.part_limits import LimitExceeded, PartLimits, check_counts
from impactnet.models.compound.scene_parts import compound_parts
from impactnet.models.scene_fields import SceneError
from impactnet.service.api.schemas import OBJECT_NAME_MAX, Body, ContactRequest
from impactnet.service.codecs.pairs import quaternion_of, unknown_object_reason
from impactnet.service.compound_solve import Group, box_parts
from impactnet.service.errors import InputError, LimitRefused
from impactnet.service.scene import SceneView


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


def _inline(body: Body, side: str, limits: PartLimits, notes: list[str]) -> tuple:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", HullWarning)
        try:
            parts = TransientParts(compound_parts({"parts": body.parts}, side, "request",
                                                  limits))
        except LimitExceeded as exc:
            raise LimitRefused("geometry_too_large", exc.path, exc.reason, exc.limit) from None
        except SceneError as exc:
            raise InputError(exc.path, exc.reason, type_="invalid_part") from None
    notes += [str(w.message).removeprefix("request: ") for w in caught]
    return parts


def _parts(body: Body, side: str, scene: SceneView, limits: PartLimits,
           notes: list[str]) -> tuple:
    if body.parts is not None:
        return _inline(body, side, limits, notes)
    if body.object is not None:
        view = scene.with_compound
        index = view.index_of(body.object)
        if index < 0:
            raise InputError(f"{side}.object", unknown_object_reason([body.object], scene),
                             type_="unknown_object")
        return scene.parts_of(index, view.sizes[index])
    return box_parts(body.size)


#: Hull corners whose square costs about one box-pair solve to build a hull of (Qhull and
#: the face and edge tables: a 512-corner frustum takes ~0.1 s, ~4,000 box-pair solves).
CORNERS_SQUARED_PER_UNIT = 64


def inline_cost(request: ContactRequest, limits: PartLimits) -> float:
    """The cost (box-pair solves) of building a request's inline parts, from their tables as
    given; counts past a limit are refused here already (413 ``geometry_too_large``)."""
    cost = 0.0
    for side, body in (("a", request.a), ("b", request.b)):
        if body.parts is None:
            continue
        try:
            corners = check_counts(body.parts, f"{side}.parts", limits, "request")
        except LimitExceeded as exc:
            raise LimitRefused("geometry_too_large", exc.path, exc.reason, exc.limit) \
                from None
        cost += corners * corners / CORNERS_SQUARED_PER_UNIT
    return cost


def _corners(parts) -> int:
    return sum(len(p.vertices()) for p in parts)


def inline_group(request: ContactRequest, scene: SceneView,
                 limits: PartLimits) -> tuple[Group, list[str]]:
    """The pair of a request with an inline body as one :class:`Group` (one row), and the
    warnings (meshes replaced by their hull)."""
    notes: list[str] = []
    sides, poses = [], []
    for side, body in (("a", request.a), ("b", request.b)):
        sides.append(_parts(body, side, scene, limits, notes))
        poses += [np.array([body.position], np.float64),
                  np.array([quaternion_of(body, side, request.euler_convention)])]
        if body.parts is not None and limits.max_vertices is not None:
            # the request's corners together: B's parts get what A's left
            limits = replace(limits, max_vertices=max(0, limits.max_vertices
                                                      - _corners(sides[-1])))
    return Group(np.zeros(1, np.int64), sides[0], sides[1], tuple(poses)), notes
