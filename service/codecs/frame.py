"""A frame's bodies (POST /v2/frame, POST /v2/worlds) as
:class:`~impactnet.models.frame.Bodies`: from JSON (a list of body objects, each a pair's body with
an ``id``) or from npz columns (``id``, ``object`` | ``size``, ``position``, one orientation,
optionally ``contype`` and ``conaffinity``; one row per body). A refusal names the body by its id.
"""
from __future__ import annotations

import re

import numpy as np
import orjson

from impactnet.models.dispatch import Shape
from impactnet.models.dispatch.shapes import Shapes
from impactnet.models.frame import Bodies
from impactnet.service.codecs.columns import body_arrays, body_columns, row_count
from impactnet.service.codecs.npz import Layout
from impactnet.service.codecs.pair import body_shape, quaternion_of
from impactnet.service.codecs.requests import OBJECT_NAME_MAX, FrameBody
from impactnet.service.errors import InputError, LimitRefused, ServiceError
from impactnet.service.scene import SceneView

#: The columns of an npz frame.
FRAME_COLUMNS = ("id", "object", "size", "position", "quaternion", "matrix", "euler",
                 "contype", "conaffinity")
#: Largest filter mask (32 bits, as MuJoCo's).
MASK_MAX = 2**32 - 1
#: A field of one body of a frame: ``bodies[3].position``.
_BODY_FIELD = re.compile(r"^bodies\[(\d+)\]")


def json_bodies(bodies: list[FrameBody], scene: SceneView, limits, convention: str,
                notes: list[str], field: str = "bodies") -> Bodies:
    """The bodies of a JSON frame or world (shapes shared where bodies name the same object
    or size; inline parts built within ``limits``)."""
    shapes: list[Shape] = []
    slots: dict = {}
    index, positions, quaternions, contype, conaffinity = [], [], [], [], []
    for k, body in enumerate(bodies):
        path = f"{field}[{k}]"
        key = ("object", body.object) if body.object is not None else (
            ("size", tuple(body.size)) if body.size is not None else ("parts", k))
        if key not in slots:
            slots[key] = len(shapes)
            shapes.append(body_shape(body, path, scene, limits, notes))
        index.append(slots[key])
        positions.append(body.position)
        quaternions.append(quaternion_of(body, path, convention))
        contype.append(1 if body.contype is None else body.contype)
        conaffinity.append(1 if body.conaffinity is None else body.conaffinity)
    return _bodies([b.id for b in bodies], shapes, index, positions, quaternions, contype,
                   conaffinity, field)


def _bodies(ids, shapes, index, positions, quaternions, contype, conaffinity,
            field: str) -> Bodies:
    seen: dict[str, int] = {}
    for k, body_id in enumerate(ids):
        first = seen.setdefault(body_id, k)
        if first != k:
            raise InputError(f"{field}[{k}].id", f"id {body_id!r} is also {field}[{first}]'s; "
                             "ids must be unique", type_="duplicate_id")
    return Bodies(tuple(ids), tuple(shapes), np.asarray(index, np.int64),
                  np.asarray(positions, np.float64).reshape(-1, 3),
                  np.asarray(quaternions, np.float64).reshape(-1, 4),
                  np.asarray(contype, np.int64), np.asarray(conaffinity, np.int64))


def _ids(columns: dict, n: int) -> list[str]:
    if "id" not in columns:
        raise InputError("id", "required column", type_="missing")
    ids = np.asarray(columns["id"])
    if ids.dtype.kind != "U" or ids.shape != (n,):
        raise InputError("id", f"expected {n} strings, one per body", type_="string_type")
    if ids.dtype.itemsize // 4 > OBJECT_NAME_MAX:
        raise InputError("id", f"ids are at most {OBJECT_NAME_MAX} characters",
                         type_="string_too_long")
    return ids.tolist()


def _mask(columns: dict, name: str, n: int) -> np.ndarray:
    if name not in columns:
        return np.ones(n, np.int64)
    values = np.asarray(columns[name])
    if values.dtype.kind not in "iu" or values.shape not in ((), (n,)):
        raise InputError(name, f"expected integers, one or {n}", type_="int_type")
    bad = np.flatnonzero((np.broadcast_to(values, (n,)) < 0) |
                         (np.broadcast_to(values, (n,)) > MASK_MAX))
    if bad.size:
        raise InputError(name, f"outside [0, {MASK_MAX}]", bad, type_="out_of_range")
    return np.broadcast_to(values, (n,)).astype(np.int64)


def npz_bodies(columns: dict, scene: SceneView, convention: str, max_bodies: int) -> Bodies:
    """The bodies of an npz frame (module docstring)."""
    unknown = sorted(set(columns) - set(FRAME_COLUMNS))
    if unknown:
        raise _unknown_frame_column(unknown[0])
    parsed, per_row = body_columns(columns, "")
    n = row_count(parsed, per_row, max_bodies, "frame", too_many_bodies)
    extra: list = []
    shape, position, quaternion = body_arrays(parsed, "", n, scene, convention, extra)
    shapes = Shapes(scene.shapes, np.concatenate(extra) if extra else None)
    used, index = np.unique(shape, return_inverse=True)
    return _bodies(_ids(columns, n), [shapes[k] for k in used], index.reshape(-1), position,
                   quaternion, _mask(columns, "contype", n), _mask(columns, "conaffinity", n),
                   "bodies")


def allowed_pairs(bodies: Bodies, scene: SceneView) -> np.ndarray:
    """(s, s) bool over ``bodies.shapes``: the pairs the scene lists, for two scene objects;
    every pair with a raw size or inline parts."""
    names = [s.name for s in bodies.shapes]
    listed = {frozenset(p) for p in scene.pairs}
    return np.array([[a is None or b is None or frozenset((a, b)) in listed for b in names]
                     for a in names], bool).reshape(len(names), len(names))


def ids_of(raw: bytes) -> list | None:
    """The ``id`` of each of a frame's JSON bodies as sent (None where a body has none), or
    None when the body is not such JSON (for :func:`name_bodies`)."""
    try:
        listed = orjson.loads(raw).get("bodies")
    except (orjson.JSONDecodeError, AttributeError):
        return None
    if not isinstance(listed, list):
        return None
    return [b.get("id") if isinstance(b, dict) else None for b in listed]


def name_bodies(exc: ServiceError, ids: list | None) -> ServiceError:
    """A 422 of a frame with each ``bodies[k]`` field named by the body's id too (``ids``:
    the bodies' ids by index)."""
    if not ids or exc.status_code != 422:
        return exc
    detail = []
    for entry in exc.items:
        found = _BODY_FIELD.match(entry.get("field", ""))
        k = int(found.group(1)) if found else None
        body_id = ids[k] if k is not None and k < len(ids) else None
        if isinstance(body_id, str):
            field = entry["field"].replace(f"[{k}]", f"[{k}] (id {body_id!r})", 1)
            entry = {**entry, "field": field, "id": body_id}
        detail.append(entry)
    message = "; ".join(f"{d['field']}: {d['reason']}" for d in detail[:5])
    return ServiceError(exc.status_code, exc.error, message or exc.message, detail,
                        exc.headers, **exc.extra)


def _frame_tail(column: str):
    return {"id": None, "object": None, "size": (3,), "position": (3,), "quaternion": (4,),
            "matrix": (3, 3), "euler": (3,), "contype": (), "conaffinity": ()}[column]


def too_many_bodies(n: int, cap: int) -> LimitRefused:
    """413 ``too_many_bodies``: a frame (its world included) or a world past the cap."""
    return LimitRefused("too_many_bodies", "bodies", f"{n} bodies in one frame or world; the "
                        f"limit is {cap}", "max_frame_bodies")


def _unknown_frame_column(column: str) -> InputError:
    return InputError(column, f"unknown column; columns are {', '.join(FRAME_COLUMNS)}",
                      type_="extra_forbidden")


#: An npz frame's layout (:mod:`impactnet.service.codecs.npz`).
FRAME_NPZ = Layout(FRAME_COLUMNS, _frame_tail, too_many_bodies, _unknown_frame_column)
