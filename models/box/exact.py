"""The exact box-box contact solver: oracle, fallback and yardstick of impactnet.

Stages (each pair independently, all pairs at once in vectorised float64 NumPy):

1. Inputs broadcast to N pairs and are validated (sizes > 0, finite poses, quaternions of
   norm >= 1e-6, normalised). The pair is expressed in A's local frame: ``t = R_A^T (p_B -
   p_A)``, ``R = R_A^T R_B``, so a pose 1e6 m from the origin gives the same answer as at it
   (:mod:`impactnet.models.box.local_frame`).
2. Separating-axis test over the 15 axes (:mod:`impactnet.models.box.sat`): the axis of least
overlap gives
   the normal (oriented from A towards B) and the depth, under the tie rule documented there
   (a cross axis within an angle band of a face normal is that face's contact; an edge-edge
   contact needs a real crossing of the edges; :func:`contact_axes`).
3. Manifold (:mod:`impactnet.models.box.manifold`, :mod:`impactnet.models.box.clip`): face axes clip
the incident face
   against the reference face, edge axes take the closest points of the two supporting edges.
4. Point: for a face axis, the centre of pressure of the footprint of every incident face
   that looks towards the reference face (:mod:`impactnet.models.box.pressure`); for an edge axis,
   the
   midpoint of the edges' closest points. A face contact's depth is the SAT overlap along its
   normal, or the deepest point of the footprint where that is shallower (the incident box's
   deepest vertex hangs beyond the reference face, e.g. a tilted container overhanging).
   Everything is mapped back to the world frame (:func:`to_world`).

Vectorised layout. The pairs go through stages 1-4 in blocks of :data:`CHUNK_ROWS`, small
enough that a block's working set stays in the CPU cache. Inside a block every quantity is a
column: one contiguous (m,) float64 array per vector component or matrix entry, with the
formulas written out term by term (NumPy is fast on long contiguous arrays and slow on
(m, 3, 3) stacks). Face manifolds are computed only for face-axis rows, edge contacts only
for edge-axis rows.

A single pair (N = 1) takes a pure-Python path (:mod:`impactnet.models.box.exact_one`) that skips
NumPy's
per-call overhead. Both paths evaluate the same formulas with their terms in the same order,
so they round identically and give the same answer to the last bit (tested); they may differ
only where a length compared with a tolerance is computed as ``sqrt(x*x + y*y)`` here and
``math.hypot`` there, i.e. at a tolerance boundary.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box import local_frame as lf
from impactnet.models.box import manifold as mf
from impactnet.models.box import pressure as pr
from impactnet.models.box import sat
from impactnet.models.box.exact_one import box_box_one, single_pair
from impactnet.models.contacts import Contacts
from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import QUATERNION_MIN_NORM, validate_quaternion

#: Pairs per block of the vectorised path: a block's live (m,) float64 columns should stay in
#: the CPU cache, while each of its ~1000 NumPy calls (~1 us of overhead each) covers many
#: pairs. Tuned on one core with 1 MB of L2: 8192-16384 are within a few per cent.
CHUNK_ROWS = 12288
#: Input widths, in the order of the solver's arguments.
_WIDTHS = (3, 3, 4, 3, 3, 4)
_NAMES = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
_XYZ = np.arange(3)[:, None]  # component offsets, to scatter (3, k) columns into (n, 3) rows


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


def _checked_inputs(values):
    """Validate the six inputs field by field; raises the precise error of the first fault."""
    rows = [_as_rows(value, width, name) for value, width, name in zip(values, _WIDTHS, _NAMES)]
    lengths = {len(r) for r in rows} - {1}
    if len(lengths) > 1:
        raise InvalidBoxError("pairs", [], f"inputs do not broadcast: row counts {sorted(lengths)}")
    n = lengths.pop() if lengths else 1
    rows = [np.broadcast_to(r, (n, r.shape[1])) for r in rows]
    for name, size in (("size_a", rows[0]), ("size_b", rows[3])):
        bad = ~(size > 0).all(axis=1)
        if bad.any():
            raise InvalidBoxError(name, np.flatnonzero(bad), "sizes must be > 0")
        bad = ~((size >= SIZE_MIN_M) & (size <= SIZE_MAX_M)).all(axis=1)
        if bad.any():
            raise InvalidBoxError(name, np.flatnonzero(bad),
                                  f"sizes must be in [{SIZE_MIN_M:g}, {SIZE_MAX_M:g}] m")
    for name, position in (("position_a", rows[1]), ("position_b", rows[4])):
        bad = ~(np.abs(position) <= POSITION_MAX_M).all(axis=1)
        if bad.any():
            raise InvalidBoxError(name, np.flatnonzero(bad),
                                  f"|coordinates| must be <= {POSITION_MAX_M:g} m")
    rows[2] = validate_quaternion(rows[2])
    rows[5] = validate_quaternion(rows[5])
    return tuple(rows)


def _in_domain(rows) -> bool:
    """Whole-array test: every size and position within :mod:`impactnet.models.domain`."""
    sizes_ok = all(((r >= SIZE_MIN_M) & (r <= SIZE_MAX_M)).all() for r in (rows[0], rows[3]))
    return sizes_ok and all((np.abs(r) <= POSITION_MAX_M).all() for r in (rows[1], rows[4]))


def unit_quaternions(q: np.ndarray):
    """Rows of q (n, 4) divided by their norm, summed as the scalar path does; None if any
    norm is below the minimum."""
    square = q * q
    norm = np.sqrt(square[:, 0] + square[:, 1] + square[:, 2] + square[:, 3])
    if not (norm >= QUATERNION_MIN_NORM).all():
        return None
    return q / norm[:, None]


def prepare_inputs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """Validate and broadcast the six inputs to N rows each.

    Valid input is checked with a few whole-array tests; only when one fails are the fields
    checked one by one (:func:`_checked_inputs`) to raise the precise error.

    Returns
    -------
    tuple of ndarray
        ``size_a (n, 3), position_a (n, 3), quaternion_a (n, 4), size_b, position_b,
        quaternion_b``, float64, quaternions normalised.
    """
    values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    rows = []
    for value, width in zip(values, _WIDTHS):
        array = np.asarray(value, dtype=np.float64)
        if array.ndim not in (1, 2) or array.shape[-1] != width or not np.isfinite(array).all():
            return _checked_inputs(values)
        rows.append(array.reshape(-1, width))
    lengths = {len(r) for r in rows} - {1}
    if len(lengths) > 1 or not _in_domain(rows):
        return _checked_inputs(values)
    n = lengths.pop() if lengths else 1
    for k in (2, 5):
        rows[k] = unit_quaternions(rows[k])
        if rows[k] is None:
            return _checked_inputs(values)
    return tuple(r if len(r) == n else np.broadcast_to(r, (n, r.shape[1])) for r in rows)


def box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b) -> Contacts:
    """Exact contact of N box pairs.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,) or (n, 3)
        Full edge lengths (metres), in [1e-6, 1e6] (:mod:`impactnet.models.domain`).
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Box centres in the world frame (metres), |coordinates| <= 1e9.
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Orientations (w, x, y, z); normalised here, norm < 1e-6 is an error.

    Returns
    -------
    Contacts
        N rows; see :class:`impactnet.models.contacts.Contacts`.

    Raises
    ------
    InvalidBoxError, impactnet.models.geometry.rotations.InvalidRotationError
        Non-finite input, size <= 0 or outside the domain, degenerate quaternion or
        non-broadcasting shapes; the error names the field and the rows.
    """
    single = single_pair(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    if single is not None:
        return box_box_one(*single)
    inputs = prepare_inputs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    return box_box_batch(*inputs)


def box_box_batch(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """Vectorised solver on validated (n, .) float64 inputs; see :func:`box_box`.

    The pairs are solved in blocks of :data:`CHUNK_ROWS`: stage 1
    (:func:`impactnet.models.box.local_frame.
    local_pose`), stages 2-3 (:func:`solve_local`), stage 4 (:func:`to_world`).
    """
    inputs = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    n = len(size_a)
    out = {
        "colliding": np.empty(n, bool), "normal": np.empty((n, 3)), "depth": np.empty(n),
        "point": np.empty((n, 3)), "contact_type_code": np.empty(n, np.int8),
        "feature_a": np.empty(n, np.int8), "feature_b": np.empty(n, np.int8),
        "axis": np.empty(n, np.int8),
        "manifold_points": np.zeros((n, ct.MAX_MANIFOLD_POINTS, 3)),
        "manifold_depths": np.zeros((n, ct.MAX_MANIFOLD_POINTS)),
        "manifold_count": np.empty(n, np.int8), "pressure": np.empty(n),
    }
    for start in range(0, n, CHUNK_ROWS):
        block = lf.input_columns(inputs, start, min(n, start + CHUNK_ROWS))
        pose, rot_a = lf.local_pose(block)
        local = solve_local(pose)
        to_world(local, rot_a, block, {name: value[start:start + block.shape[1]]
                                       for name, value in out.items()})
    return Contacts(**out)


def contact_axes(pose: lf.LocalPose):
    """Stage 2: each pair's contact axis by the tie rule of :mod:`impactnet.models.box.sat` (rules
    1-3).

    Returns
    -------
    colliding : ndarray of bool, shape (m,)
    axis : ndarray of int8, shape (m,)
    depth : ndarray, shape (m,)
        Overlap along the axis (metres).
    normal : ndarray, shape (3, m)
        The axis oriented from A towards B, A's frame.
    edge : tuple
        ``(rows, point (3, e), feature_a, feature_b)`` of the e edge-edge contacts, points in
        A's frame (metres).
    """
    overlap, sines = sat.overlap_columns(pose)
    colliding, axis, depth, face_axis, face_depth = sat.choose_axis(overlap, sines, pose.r,
                                                                    pose.scale)
    normal = sat.oriented_normal(pose, axis)
    rows = np.flatnonzero(colliding & (axis >= 6))
    point, edge_a, edge_b, inside = mf.edge_contact(pose.take(rows), np.take(normal, rows, 1),
                                                    axis[rows])
    if not inside.all():  # rule 3: the edges do not really cross, the face axis answers
        back = rows[~inside]
        axis[back], depth[back] = face_axis[back], face_depth[back]
        normal[:, back] = sat.oriented_normal(pose.take(back), axis[back])
        rows, point = rows[inside], point[:, inside]
        edge_a, edge_b = edge_a[inside], edge_b[inside]
    return colliding, axis, depth, normal, (rows, point, edge_a, edge_b)


def solve_local(pose: lf.LocalPose) -> dict:
    """Solve m pairs in A's frame (stages 2 and 3).

    Returns
    -------
    dict
        The `Contacts` fields of the block in A's frame, vectors as (3, m) arrays, plus
        ``edge_rows`` and ``face_entries``: the face manifolds as (row, slot, point (3, E),
        depth) per manifold point, points in A's frame (metres).
    """
    m = pose.data.shape[1]
    colliding, axis, depth, normal, edge = contact_axes(pose)
    out = {
        "colliding": colliding, "axis": axis, "depth": depth, "normal": normal,
        "point": np.zeros((3, m)), "contact_type_code": np.zeros(m, np.int8),  # 0: separated
        "feature_a": np.full(m, bf.NO_FEATURE, np.int8),
        "feature_b": np.full(m, bf.NO_FEATURE, np.int8),
        "manifold_count": np.zeros(m, np.int8),
        "pressure": np.zeros(m),  # face contacts' int (d + tau) dA; 0 for edge-edge, separated
    }
    _fill_face_rows(out, np.flatnonzero(colliding & (axis < 6)), pose)
    _fill_edge_rows(out, *edge)
    return out


def _fill_face_rows(out, rows, pose):
    """Face-axis contacts: clip and centre of pressure in the reference box's frame, mapped
    back to A's frame."""
    axis = out["axis"][rows]
    ref_is_b = axis >= 3
    scale = pose.scale[rows]
    frame = mf.ReferenceFrame(pose, rows, ref_is_b, axis % 3)
    (points, depths, entry_rows, slots, count, inc_feature, rank, ref_face,
     deepest) = mf.face_manifold(frame, scale)
    centre, region_depth, out["pressure"][rows] = pr.centre_of_pressure(frame, scale, deepest)
    point = mf.from_reference(axis % 3, *centre)
    sat_depth = out["depth"][rows]
    shallower = region_depth < sat_depth - pr.REGION_DEPTH_TOL_REL * scale
    out["depth"][rows] = np.where((region_depth >= 0.0) & shallower, region_depth, sat_depth)
    flip = np.flatnonzero(ref_is_b)  # the reference frame is B's: map to A's
    if flip.size:
        point[:, flip] = lf.b_to_a(pose, rows[flip], point[:, flip])
    flip = np.flatnonzero(ref_is_b[entry_rows])
    if flip.size:
        points[:, flip] = lf.b_to_a(pose, rows[entry_rows[flip]], points[:, flip])
    out["point"][:, rows] = point
    out["face_entries"] = (rows[entry_rows], slots, points, depths)
    out["manifold_count"][rows] = count
    (out["contact_type_code"][rows], out["feature_a"][rows],
     out["feature_b"][rows]) = mf.face_labels(ref_is_b, inc_feature, rank, ref_face)


def _fill_edge_rows(out, rows, point, edge_a, edge_b):
    """Edge-axis contacts: a single point, the midpoint of the two edges' closest points."""
    out["point"][:, rows] = point
    out["edge_rows"] = rows
    out["manifold_count"][rows] = 1
    out["feature_a"][rows] = edge_a
    out["feature_b"][rows] = edge_b
    out["contact_type_code"][rows] = ct.EDGE_EDGE


def to_world(local: dict, rot_a, block, out: dict) -> None:
    """Map a :func:`solve_local` result from A's frame to the world frame, into ``out``.

    ``rot_a`` (9, m) holds A's rotation, ``block`` the input columns of the m pairs and
    ``out`` the m output rows (views into the `Contacts` arrays).
    """
    position_a = block[lf.INPUT_SLICES[1]]
    position_b = block[lf.INPUT_SLICES[4]]
    for name in ("colliding", "depth", "axis", "contact_type_code", "feature_a", "feature_b",
                 "manifold_count", "pressure"):
        out[name][:] = local[name]
    out["normal"][:] = lf.matvec(rot_a, local["normal"]).T
    point = position_a + lf.matvec(rot_a, local["point"])
    separated = np.flatnonzero(~local["colliding"])
    if separated.size:  # the midpoint of the centres, without the rotation round trip
        point[:, separated] = 0.5 * (position_a[:, separated] + position_b[:, separated])
    out["point"][:] = point.T
    # Manifold points: edge rows have one (the point), face rows their entries; written
    # through flat indices into the (m, 8, 3) block, the cheapest scatter NumPy offers.
    points, depths = out["manifold_points"].reshape(-1), out["manifold_depths"].reshape(-1)
    edge_rows = local["edge_rows"]
    slot = edge_rows * ct.MAX_MANIFOLD_POINTS
    points[3 * slot + _XYZ] = np.take(point, edge_rows, axis=1)
    depths[slot] = local["depth"][edge_rows]
    rows, slots, face_points, face_depths = local["face_entries"]
    slot = rows * ct.MAX_MANIFOLD_POINTS + slots
    world = np.take(position_a, rows, axis=1) + lf.matvec(np.take(rot_a, rows, axis=1),
                                                          face_points)
    points[3 * slot + _XYZ] = world
    depths[slot] = face_depths
