"""A single pair (POST /v1/contact) with a compound body given inline: ``parts`` in the scene
files' format (:mod:`impactnet.models.compound.scene_parts`; a mesh as ``{format, data}``
base64). Bad parts are 422 naming the field (``a.parts[2].mesh.data``): an unknown shape or
key, a mesh that does not load, a flat hull, a part inside another. The other body may be a
scene object (box or compound) or a raw size."""
from __future__ import annotations

import warnings

from impactnet.models.compound.meshes import HullWarning
from impactnet.models.compound.parts import BoxPart
from impactnet.models.compound.scene_parts import compound_parts
from impactnet.models.scene_fields import SceneError
from impactnet.service.api.errors import InputError
from impactnet.service.api.schemas import Body, ContactRequest
from impactnet.service.codecs.pairs import quaternion_of, unknown_object_reason
from impactnet.service.compound_solve import row_json, solve_parts
from impactnet.service.scene import SceneView


def _parts(body: Body, side: str, scene: SceneView, notes: list[str]) -> tuple:
    if body.parts is not None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", HullWarning)
            try:
                parts = compound_parts({"parts": body.parts}, side, "request")
            except SceneError as exc:
                raise InputError(exc.path, exc.reason, type_="invalid_part") from None
        notes += [str(w.message).removeprefix("request: ") for w in caught]
        return parts
    if body.object is not None:
        view = scene.with_compound
        index = view.index_of(body.object)
        if index < 0:
            raise InputError(f"{side}.object", unknown_object_reason([body.object], scene),
                             type_="unknown_object")
        return scene.parts_of(index, view.sizes[index])
    return (BoxPart("box", tuple(body.size)),)


def inline_answer(request: ContactRequest, scene: SceneView, max_per_pose: int) -> dict:
    """The compound answer of a pair with a body given by ``parts`` (JSON-ready, without
    ``mode`` and ``model_version``); ``warnings`` lists meshes replaced by their hull."""
    notes: list[str] = []
    sides = []
    for side, body in (("a", request.a), ("b", request.b)):
        parts = _parts(body, side, scene, notes)
        sides += [parts, body.position, quaternion_of(body, side, request.euler_convention)]
    answer = row_json(solve_parts(*sides, max_per_pose), 0)
    return answer | ({"warnings": notes} if notes else {})
