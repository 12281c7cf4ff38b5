"""The exact box-box contact solver: oracle, fallback and yardstick of impactnet.

Stages (each pair independently, all pairs at once in vectorised float64 NumPy):

1. Inputs broadcast to N pairs and are validated (sizes > 0, finite poses, quaternions of
   norm >= 1e-6, normalised). The pair is expressed in A's local frame: ``t = R_A^T (p_B -
   p_A)``, ``R = R_A^T R_B``, so a pose 1e6 m from the origin gives the same answer as at it.
2. Separating-axis test over the 15 axes (:mod:`models.sat`): the axis of least overlap gives
   the normal (oriented from A towards B) and the depth; ties are broken by the documented
   rule there (face axes first, then lowest axis id), never by a percentage bias.
3. Manifold (:mod:`models.manifold`): face axes clip the incident face against the reference
   face, edge axes take the closest points of the two supporting edges.
4. The point is the depth-weighted mean of the mid-surface manifold points; everything is
   mapped back to the world frame.

A single pair (N = 1) takes a pure-Python path (:mod:`models.exact_scalar`) that skips NumPy's
per-call overhead and gives the same answer as the batch path (tested).
"""
from __future__ import annotations

import numpy as np

from models import box_features as bf
from models import contacts as ct
from models import manifold as mf
from models import sat
from models.contacts import Contacts
from models.exact_scalar import box_box_one, single_pair
from models.rotations import quaternion_to_matrix, validate_quaternion

class InvalidBoxError(ValueError):
    """A box input is not usable; ``field`` names it and ``rows`` the offending pairs."""

    def __init__(self, field: str, rows, reason: str):
        self.field, self.rows = field, np.asarray(rows).tolist()
        super().__init__(f"{field}: {reason} (rows {self.rows[:10]})")


def _as_rows(value, width: int, field: str) -> np.ndarray:
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0 or array.shape[-1] != width or array.ndim > 2:
        raise InvalidBoxError(field, [], f"expected shape ({width},) or (n, {width}), got "
                              f"{array.shape}")
    array = array.reshape(-1, width)
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        raise InvalidBoxError(field, np.flatnonzero(bad), "not finite")
    return array


def prepare_inputs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """Validate and broadcast the six inputs to N rows each.

    Returns
    -------
    tuple of ndarray
        ``size_a (n, 3), position_a (n, 3), quaternion_a (n, 4), size_b, position_b,
        quaternion_b``, float64, quaternions normalised.
    """
    rows = [_as_rows(size_a, 3, "size_a"), _as_rows(position_a, 3, "position_a"),
            _as_rows(quaternion_a, 4, "quaternion_a"), _as_rows(size_b, 3, "size_b"),
            _as_rows(position_b, 3, "position_b"), _as_rows(quaternion_b, 4, "quaternion_b")]
    lengths = {len(r) for r in rows} - {1}
    if len(lengths) > 1:
        raise InvalidBoxError("pairs", [], f"inputs do not broadcast: row counts {sorted(lengths)}")
    n = lengths.pop() if lengths else 1
    rows = [np.broadcast_to(r, (n, r.shape[1])) for r in rows]
    for name, size in (("size_a", rows[0]), ("size_b", rows[3])):
        bad = ~(size > 0).all(axis=1)
        if bad.any():
            raise InvalidBoxError(name, np.flatnonzero(bad), "sizes must be > 0")
    rows[2] = validate_quaternion(rows[2])
    rows[5] = validate_quaternion(rows[5])
    return tuple(rows)


def box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b) -> Contacts:
    """Exact contact of N box pairs.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,) or (n, 3)
        Full edge lengths (metres), > 0.
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Box centres in the world frame (metres).
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Orientations (w, x, y, z); normalised here, norm < 1e-6 is an error.

    Returns
    -------
    Contacts
        N rows; see :class:`models.contacts.Contacts`.

    Raises
    ------
    InvalidBoxError, models.rotations.InvalidRotationError
        Non-finite input, size <= 0, degenerate quaternion or non-broadcasting shapes.
    """
    single = single_pair(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    if single is not None:
        return box_box_one(*single)
    inputs = prepare_inputs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    return box_box_batch(*inputs)


def box_box_batch(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """Vectorised solver on validated (n, .) float64 inputs; see :func:`box_box`."""
    rot_a = quaternion_to_matrix(quaternion_a)
    rot_b = quaternion_to_matrix(quaternion_b)
    rotation = np.swapaxes(rot_a, 1, 2) @ rot_b
    translation = np.einsum("nij,ni->nj", rot_a, position_b - position_a)
    half_a, half_b = 0.5 * size_a, 0.5 * size_b
    local = solve_local(half_a, half_b, rotation, translation)
    return to_world(local, rot_a, position_a, position_b)


def solve_local(half_a, half_b, rotation, translation) -> dict:
    """Solve N pairs in A's frame; returns a dict of the `Contacts` fields in A's frame."""
    n = translation.shape[0]
    scale = sat.pair_scale(half_a, half_b)
    overlap, unit_axes = sat.overlaps(half_a, half_b, rotation, translation)
    colliding, axis = sat.choose_axis(overlap, scale)
    normal = sat.oriented_normal(unit_axes, axis, translation)
    depth = np.where(colliding, np.maximum(np.take_along_axis(overlap, axis[:, None], 1)[:, 0],
                                           0.0), 0.0)
    out = {
        "colliding": colliding, "normal": normal, "depth": depth,
        "point": 0.5 * translation,
        "contact_type_code": np.zeros(n, np.int8),
        "feature_a": np.full(n, bf.NO_FEATURE, np.int8),
        "feature_b": np.full(n, bf.NO_FEATURE, np.int8),
        "axis": axis.astype(np.int8),
        "manifold_points": np.zeros((n, ct.MAX_MANIFOLD_POINTS, 3)),
        "manifold_depths": np.zeros((n, ct.MAX_MANIFOLD_POINTS)),
        "manifold_count": np.zeros(n, np.int8),
    }
    face_rows = np.flatnonzero(colliding & (axis < 6))
    if face_rows.size:
        _fill_face_rows(out, face_rows, half_a, half_b, rotation, translation, axis, scale)
    edge_rows = np.flatnonzero(colliding & (axis >= 6))
    if edge_rows.size:
        _fill_edge_rows(out, edge_rows, half_a, half_b, rotation, translation)
    return out


def _fill_face_rows(out, rows, half_a, half_b, rotation, translation, axis, scale):
    """Face-axis contacts: clip in the reference box's frame, map back to A's frame."""
    ref_is_b = axis[rows] >= 3
    rot = rotation[rows]
    rot_t = np.swapaxes(rot, 1, 2)
    t = translation[rows]
    flip = ref_is_b[:, None]
    half_ref = np.where(flip, half_b[rows], half_a[rows])
    half_inc = np.where(flip, half_a[rows], half_b[rows])
    rot_ri = np.where(flip[:, :, None], rot_t, rot)
    t_ri = np.where(flip, -np.einsum("nij,nj->ni", rot_t, t), t)
    ref_axis = axis[rows] % 3
    ref_sign = sat.sign_nonnegative(np.take_along_axis(t_ri, ref_axis[:, None], 1)[:, 0])

    points, depths, count, inc_feature, rank = mf.face_manifold(
        half_ref, half_inc, rot_ri, t_ri, ref_axis, ref_sign, scale[rows])
    in_a = np.where(flip[:, :, None], t[:, None, :] + np.einsum("nij,nkj->nki", rot, points), points)
    in_a *= (np.arange(points.shape[1])[None, :] < count[:, None])[:, :, None]
    out["manifold_points"][rows] = in_a
    out["manifold_depths"][rows] = depths
    out["manifold_count"][rows] = count
    out["point"][rows] = mf.weighted_point(in_a, depths, count, scale[rows])

    ref_face = bf.face_id(ref_axis, ref_sign < 0)
    out["feature_a"][rows] = np.where(ref_is_b, inc_feature, ref_face)
    out["feature_b"][rows] = np.where(ref_is_b, ref_face, inc_feature)
    face_ref_codes = np.array([0, ct.FACE_VERTEX, ct.FACE_EDGE, ct.FACE_FACE])
    face_inc_codes = np.array([0, ct.VERTEX_FACE, ct.EDGE_FACE, ct.FACE_FACE])
    out["contact_type_code"][rows] = np.where(ref_is_b, face_inc_codes[rank], face_ref_codes[rank])


def _fill_edge_rows(out, rows, half_a, half_b, rotation, translation):
    """Edge-axis contacts: a single point, the midpoint of the two edges' closest points."""
    point, edge_a, edge_b = mf.edge_contact(half_a[rows], half_b[rows], rotation[rows],
                                            translation[rows], out["normal"][rows],
                                            out["axis"][rows].astype(np.int64))
    out["point"][rows] = point
    out["manifold_points"][rows, 0] = point
    out["manifold_depths"][rows, 0] = out["depth"][rows]
    out["manifold_count"][rows] = 1
    out["feature_a"][rows] = edge_a
    out["feature_b"][rows] = edge_b
    out["contact_type_code"][rows] = ct.EDGE_EDGE


def to_world(local: dict, rot_a, position_a, position_b) -> Contacts:
    """Map a :func:`solve_local` result from A's frame to the world frame."""
    local["normal"] = np.einsum("nij,nj->ni", rot_a, local["normal"])
    point = position_a + np.einsum("nij,nj->ni", rot_a, local["point"])
    # Separated rows: the midpoint of the centres, computed without the rotation round trip.
    local["point"] = np.where(local["colliding"][:, None], point, 0.5 * (position_a + position_b))
    manifold = position_a[:, None, :] + np.einsum("nij,nkj->nki", rot_a, local["manifold_points"])
    valid = np.arange(manifold.shape[1])[None, :] < local["manifold_count"][:, None]
    local["manifold_points"] = np.where(valid[:, :, None], manifold, 0.0)
    return Contacts(**local)
