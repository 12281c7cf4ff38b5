"""One pair: a validated :class:`ContactRequest` -> :class:`PairInputs`, a `Contacts` row ->
the JSON answer. Shared helpers (orientation errors, paper angles) serve the batch path too."""
from __future__ import annotations

import logging
import math
import re

import numpy as np

from impactnet.models.box.exact import InvalidBoxError
from impactnet.models.contacts import CONTACT_TYPES, Contacts
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry import spherical
from impactnet.models.geometry.rotations import (
    QUATERNION_MIN_NORM,
    InvalidRotationError,
    quaternion_to_matrix,
    rotation_to_quaternion,
)
from impactnet.models.learned.pair_dispatch import UnsupportedPairError
from impactnet.service.api.schemas import Body, ContactRequest
from impactnet.service.errors import InputError, UnsupportedPair
from impactnet.service.predictors import PairInputs, pair_args
from impactnet.service.scene import SceneView

#: Distance (metres) from A's centre below which the impact point has no direction: 1e-12 m,
#: a millionth of the smallest accepted size (1 um).
UNDEFINED_DIRECTION_M = 1e-12
log = logging.getLogger("impactnet.service")
PAPER_ANGLE_NAMES = ("point_azimuth", "point_elevation", "force_azimuth", "force_elevation")
_ROWS_SUFFIX = re.compile(r" at rows \[.*$")
_NAMES = np.asarray(CONTACT_TYPES)


def rotation_reason(exc: InvalidRotationError) -> str:
    """The reason of a rotation error without its "invalid <field>: " prefix and row list."""
    text = str(exc)
    prefix = f"invalid {exc.field}: "
    text = text[len(prefix):] if text.startswith(prefix) else text
    return _ROWS_SUFFIX.sub("", text)


def unknown_object_reason(names, scene: SceneView) -> str:
    """Why object ``names`` cannot be used: no scene, or the scene's bodies (all of them, box
    and compound, named)."""
    if scene.name is None:
        return "no scene is loaded, so objects cannot be named; give `size` instead"
    shown = ", ".join(repr(str(n)) for n in list(names)[:5])
    bodies = sorted(set(scene.object_names) | set(scene.compound_names))
    return f"unknown object {shown}; scene {scene.name!r} has: {', '.join(bodies)}"


def _size(body: Body, side: str, scene: SceneView) -> list[float]:
    if body.size is not None:
        return body.size
    size = scene.size_of(body.object)
    if size is None:
        raise InputError(f"{side}.object", unknown_object_reason([body.object], scene),
                         type_="unknown_object")
    return size


def euler_quaternion(euler: list[float], convention: str) -> list[float]:
    """Unit quaternion (canonical w >= 0) of one Euler triple, in plain floats: the closed
    form of :func:`impactnet.models.geometry.rotations.euler_to_quaternion` (tested equal), without
    NumPy's
    per-call cost. zyx: q = qz(yaw) qy(pitch) qx(roll); xyz: q = qx(a) qy(b) qz(c)."""
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


def quaternion_of(body: Body, side: str, convention: str) -> list[float]:
    """The unit quaternion of a request body's one orientation (422 naming the field if it is
    not a rotation)."""
    q = body.quaternion
    if q is not None:  # plain floats: the single-pair path avoids NumPy's per-call cost
        norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        if norm < QUATERNION_MIN_NORM:
            raise InputError(f"{side}.quaternion", f"norm below {QUATERNION_MIN_NORM:g}: "
                             "not a rotation", type_="zero_quaternion")
        return [v / norm for v in q]
    if body.euler is not None:  # finite and bounded (schema): always a rotation
        return euler_quaternion(body.euler, convention)
    try:
        return rotation_to_quaternion(matrix=body.matrix)[0].tolist()
    except InvalidRotationError as exc:
        raise InputError(f"{side}.matrix", rotation_reason(exc), type_="invalid_rotation") \
            from exc


def request_pair(request: ContactRequest, scene: SceneView) -> PairInputs:
    """The one pair of a validated request, as (1, .) float64 arrays."""
    a, b = request.a, request.b
    conv = request.euler_convention
    rows = [_size(a, "a", scene), a.position, quaternion_of(a, "a", conv),
            _size(b, "b", scene), b.position, quaternion_of(b, "b", conv)]
    objects = [scene.index_of(body.object) for body in (a, b)]
    return PairInputs(*(np.array([r], dtype=np.float64) for r in rows),
                      np.array([objects[0]]), np.array([objects[1]]))


def paper_angles(contacts: Contacts, pairs: PairInputs) -> np.ndarray:
    """The paper's four angles (n, 4), radians; NaN rows where there is no contact (or the
    point sits at A's centre, where the point's direction is undefined)."""
    out = np.full((len(contacts), 4), np.nan)
    offset = np.linalg.norm(contacts.point - pairs.position_a, axis=1)
    rows = np.flatnonzero(contacts.colliding & (offset > UNDEFINED_DIRECTION_M)
                          & (np.linalg.norm(contacts.normal, axis=1) > 0.5))
    if rows.size:
        rotation = quaternion_to_matrix(pairs.quaternion_a[rows])
        try:
            out[rows] = spherical.paper_angles(contacts.point[rows], contacts.normal[rows],
                                                pairs.position_a[rows], rotation)
        except ValueError:  # a direction that vanished in round-off: leave those rows NaN
            log.warning("paper angles undefined", exc_info=True)
    return out


_FEATURES = {i: {"id": i, "name": bf.feature_name(i), "kind": str(bf.feature_kind(i))}
             for i in range(bf.NO_FEATURE, bf.N_FEATURES)}


def _feature(fid: int) -> dict:
    return dict(_FEATURES[fid])


def contact_json(contacts: Contacts, pairs: PairInputs, mode: str, model_version: str,
                 include) -> dict:
    """Row 0 of ``contacts`` as the body of a POST /v1/contact answer (its finiteness is
    checked by the caller with :func:`check_finite`)."""
    out = {
        "colliding": bool(contacts.colliding[0]),
        "point": contacts.point[0].tolist(),
        "normal": contacts.normal[0].tolist(),
        "depth": float(contacts.depth[0]),
        "contact_type": str(_NAMES[contacts.contact_type_code[0]]),
        "feature_a": _feature(int(contacts.feature_a[0])),
        "feature_b": _feature(int(contacts.feature_b[0])),
        "axis": int(contacts.axis[0]),
        "confidence": float(contacts.confidence[0]),
        "predictor": str(contacts.predictor[0]),
        "mode": mode,
        "model_version": model_version,
    }
    if "manifold" in include:
        count = int(contacts.manifold_count[0])
        depths = [d if d > 0.0 else 0.0 for d in contacts.manifold_depths[0, :count].tolist()]
        out["manifold"] = {"count": count,
                           "points": contacts.manifold_points[0, :count].tolist(),
                           "depths": depths}  # >= 0 like `depth` (round-off: -1e-17)
    if "paper_angles" in include:
        angles = paper_angles(contacts, pairs)[0]
        out["paper_angles"] = {k: (None if math.isnan(v) else v)
                               for k, v in zip(PAPER_ANGLE_NAMES, angles.tolist(), strict=True)}
    return out


def check_finite(contacts: Contacts) -> np.ndarray:
    """Rows whose answer is not finite (never expected inside the validated input range)."""
    if len(contacts) == 1:  # plain floats: cheaper than six NumPy reductions
        values = [*contacts.point[0].tolist(), *contacts.normal[0].tolist(),
                  float(contacts.depth[0]), float(contacts.confidence[0]),
                  *contacts.manifold_points[0].ravel().tolist(),
                  *contacts.manifold_depths[0].tolist()]
        return np.zeros(0, np.int64) if all(map(math.isfinite, values)) else np.zeros(1, np.int64)
    bad = ~(np.isfinite(contacts.point).all(axis=1) & np.isfinite(contacts.normal).all(axis=1)
            & np.isfinite(contacts.depth) & np.isfinite(contacts.confidence)
            & np.isfinite(contacts.manifold_points).all(axis=(1, 2))
            & np.isfinite(contacts.manifold_depths).all(axis=1))
    return np.flatnonzero(bad)


def predict_checked(predictor, pairs: PairInputs, batch: bool = False,
                    offset: int = 0):
    """Run a predictor; input faults it finds become 422, a pair that a strict learned mode
    has no model for too (``unsupported_pair``, naming the rows of a ``batch``), non-finite
    answers too (logged: inside the validated range they are a solver bug). ``offset``: the
    batch row of ``pairs``' first row (a chunk of a batch), added to the rows reported."""
    try:
        contacts = predictor(*pair_args(pairs))
    except (InvalidBoxError, InvalidRotationError) as exc:
        rows = None if exc.rows is None else np.asarray(exc.rows) + offset
        raise InputError(exc.field, str(exc), rows, type_="invalid_box") from exc
    except UnsupportedPairError as exc:
        raise UnsupportedPair(predictor.mode, np.asarray(exc.rows) + offset,
                              exc.pairs, batch) from exc
    bad = check_finite(contacts)
    if bad.size:
        log.error("non-finite answer", extra={"predictor": predictor.mode,
                                              "rows": (bad[:10] + offset).tolist()})
        raise InputError("pairs", f"predictor {predictor.mode!r} found no finite answer for "
                         "these pairs", bad + offset, type_="numeric_range")
    return contacts
