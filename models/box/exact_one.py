"""The exact solver for one pair, in plain Python floats (the N = 1 fast path).

NumPy costs about a microsecond per call whatever the array size, and the vectorised solver
makes a few hundred calls, so a single pair is solved here with the same stages, the same
tolerances and the same tie rules as :mod:`impactnet.models.box.sat` and
:mod:`impactnet.models.box.manifold`, whose
docstrings explain them. The test suite checks that both paths agree on every fuzz sample.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from impactnet.models import contacts as ct
from impactnet.models.box.manifold import FACE_INC_CODES as FACE_INC_CODES_ARRAY
from impactnet.models.box.manifold import FACE_REF_CODES as FACE_REF_CODES_ARRAY
from impactnet.models.box.manifold import QUAD_SIGNS, SNAP_TOL_REL
from impactnet.models.box.pressure import REGION_DEPTH_TOL_REL
from impactnet.models.box.pressure_one import centre_of_pressure
from impactnet.models.box.sat_one import contact_axis, dot, sgn
from impactnet.models.box.scalar_inputs import single_pair  # noqa: F401  (re-exported: the N = 1 entry)
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import quaternion_matrix

_QUAD = [tuple(s) for s in QUAD_SIGNS.tolist()]
# impactnet.models.box.manifold's tables as Python ints (the scalar path avoids NumPy scalars).
FACE_REF_CODES = tuple(FACE_REF_CODES_ARRAY.tolist())
FACE_INC_CODES = tuple(FACE_INC_CODES_ARRAY.tolist())
_PADDING = [0.0] * (3 * ct.MAX_MANIFOLD_POINTS)


def _quat_matrix(q):
    """Rotation matrix (rows) of a unit quaternion (w, x, y, z)."""
    m = quaternion_matrix(*q)
    return m[0:3], m[3:6], m[6:9]


def _clip(quad, depth, half_u, half_w, tol):
    """Valid candidate points (u, w, depth), in the candidate order of
    :mod:`impactnet.models.box.clip`.

    Same tests and arithmetic as the batch path, with early exits: a rectangle corner is only
    tested if it is not above the reference face, and a quad edge only crosses the rectangle
    usefully if one of its ends is not above it (depth is linear along the edge).
    """
    out = []
    for (pu, pw), d in zip(quad, depth):
        if d >= -tol and abs(pu) <= half_u + tol and abs(pw) <= half_w + tol:
            out.append((min(max(pu, -half_u), half_u), min(max(pw, -half_w), half_w), d))
    cu = 0.25 * (quad[0][0] + quad[1][0] + quad[2][0] + quad[3][0])
    cw = 0.25 * (quad[0][1] + quad[1][1] + quad[2][1] + quad[3][1])
    a0, a1 = 0.5 * (quad[0][0] - quad[1][0]), 0.5 * (quad[0][1] - quad[1][1])
    b0, b1 = 0.5 * (quad[1][0] - quad[2][0]), 0.5 * (quad[1][1] - quad[2][1])
    det = a0 * b1 - a1 * b0
    len_a, len_b = math.hypot(a0, a1), math.hypot(b0, b1)
    d_c = 0.25 * (depth[0] + depth[1] + depth[2] + depth[3])
    d_a, d_b = 0.5 * (depth[0] - depth[1]), 0.5 * (depth[1] - depth[2])
    for su, sw in _QUAD:
        ru, rw = su * half_u - cu, sw * half_w - cw
        alpha = (ru * b1 - rw * b0) / det
        beta = (a0 * rw - a1 * ru) / det
        d = d_c + alpha * d_a + beta * d_b
        if d < -tol or (abs(alpha) - 1.0) * len_a > tol or (abs(beta) - 1.0) * len_b > tol:
            continue
        if min(math.hypot(su * half_u - p[0], sw * half_w - p[1]) for p in quad) > tol:
            out.append((su * half_u, sw * half_w, d))
    halves = (half_u, half_w)
    for m in range(4):
        start, end = quad[m], quad[(m + 1) % 4]
        d0, d1 = depth[m], depth[(m + 1) % 4]
        if d0 < -tol and d1 < -tol:
            continue
        edge_len = math.hypot(end[0] - start[0], end[1] - start[1])
        for coord, value in ((0, half_u), (0, -half_u), (1, half_w), (1, -half_w)):
            delta = end[coord] - start[coord]
            if delta == 0.0:
                continue
            tau = (value - start[coord]) / delta
            if not (tau * edge_len > tol and (1.0 - tau) * edge_len > tol):
                continue
            other = start[1 - coord] + tau * (end[1 - coord] - start[1 - coord])
            d = d0 + tau * (d1 - d0)
            if abs(other) < halves[1 - coord] - tol and d >= -tol:
                out.append((value, other, d) if coord == 0 else (other, value, d))
    return out


def incident_feature(depth, signs, face, tol):
    """Incident feature id and rank (1 vertex, 2 edge, 3 face), as in
    impactnet.models.box.manifold."""
    order = sorted(range(4), key=lambda m: -depth[m])
    deepest, second = signs[order[0]], signs[order[1]]
    touching = sum(1 for d in depth if d >= -tol)
    if touching >= 3:
        return face, 3
    if touching == 2:
        along = next(k for k in range(3) if deepest[k] != second[k])
        j, m = (1, 2) if along == 0 else ((0, 2) if along == 1 else (0, 1))
        return bf.EDGE_BASE + 4 * along + 2 * (deepest[j] < 0) + (deepest[m] < 0), 2
    return (bf.VERTEX_BASE + 4 * (deepest[0] < 0) + 2 * (deepest[1] < 0)
                + (deepest[2] < 0)), 1


def incident_face(h_ref, h_inc, rot_ri, t_ri, ref_axis):
    """The incident face seen from the reference box: ``(ref_sign, vertices, signs, depth,
    face)``: side of the reference face, the 4 quad vertices (reference frame), their sign
    vectors in the incident box, their depths below the reference face and the face id."""
    ref_sign = sgn(t_ri[ref_axis])
    n_inc = [ref_sign * rot_ri[ref_axis][k] for k in range(3)]
    k = max(range(3), key=lambda i: (abs(n_inc[i]), -i))
    side = -sgn(n_inc[k])
    p, q = (k + 1) % 3, (k + 2) % 3
    col = [(rot_ri[0][j], rot_ri[1][j], rot_ri[2][j]) for j in range(3)]
    centre = [t_ri[c] + side * h_inc[k] * col[k][c] for c in range(3)]
    vertices, signs = [], []
    for a, b in _QUAD:
        vertices.append([centre[c] + a * h_inc[p] * col[p][c] + b * h_inc[q] * col[q][c]
                         for c in range(3)])
        sign = [0.0, 0.0, 0.0]
        sign[k], sign[p], sign[q] = side, a, b
        signs.append(sign)
    depth = [h_ref[ref_axis] - ref_sign * v[ref_axis] for v in vertices]
    return ref_sign, vertices, signs, depth, bf.FACE_BASE + 2 * k + (side < 0)


def _face_contact(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale):
    """Manifold (points in the reference frame, depths clamped at 0), the centre of pressure
    (reference frame), the incident feature and its rank."""
    tol = SNAP_TOL_REL * scale
    ref_sign, vertices, signs, depth, face = incident_face(h_ref, h_inc, rot_ri, t_ri, ref_axis)
    u, w = (ref_axis + 1) % 3, (ref_axis + 2) % 3
    height = h_ref[ref_axis]
    quad = [(v[u], v[w]) for v in vertices]
    candidates = _clip(quad, depth, h_ref[u], h_ref[w], tol)
    candidates.sort(key=lambda c: -c[2])  # stable, as the vectorised argsort
    points = []
    for cu, cw, d in candidates[: ct.MAX_MANIFOLD_POINTS]:
        d = max(d, 0.0)
        point = [0.0, 0.0, 0.0]
        point[ref_axis] = ref_sign * height - ref_sign * 0.5 * d
        point[u], point[w] = cu, cw
        points.append((point, d))
    feature, rank = incident_feature(depth, signs, face, tol)
    corner = vertices[max(range(4), key=lambda m: (depth[m], -m))]
    deepest = max(height - ref_sign * corner[ref_axis], 0.0)
    fallback = (ref_sign * height - ref_sign * 0.5 * deepest,
                min(max(corner[u], -h_ref[u]), h_ref[u]), min(max(corner[w], -h_ref[w]), h_ref[w]))
    centre, depth, pressure = centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale,
                                                 fallback)
    return (points, centre, depth, feature, rank, bf.FACE_BASE + 2 * ref_axis + (ref_sign < 0),
            pressure)


def _transpose(m):
    return tuple(tuple(m[r][c] for r in range(3)) for c in range(3))


def apply(m, v):
    return [dot(m[0], v), dot(m[1], v), dot(m[2], v)]


def relative_frame(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """``(ha, hb, R, t, R_A)`` of one validated pair: half-extents, B's rotation and centre
    in A's frame (``R = R_A^T R_B``, ``t = R_A^T (p_B - p_A)``) and A's rotation (rows)."""
    ha = [0.5 * v for v in size_a]
    hb = [0.5 * v for v in size_b]
    pa, pb = position_a, position_b
    rot_a, rot_b = _quat_matrix(quaternion_a), _quat_matrix(quaternion_b)
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = rot_a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = rot_b
    # Each sum in the order of the batch path.
    rot = ((a00 * b00 + a10 * b10 + a20 * b20, a00 * b01 + a10 * b11 + a20 * b21,
            a00 * b02 + a10 * b12 + a20 * b22),
           (a01 * b00 + a11 * b10 + a21 * b20, a01 * b01 + a11 * b11 + a21 * b21,
            a01 * b02 + a11 * b12 + a21 * b22),
           (a02 * b00 + a12 * b10 + a22 * b20, a02 * b01 + a12 * b11 + a22 * b21,
            a02 * b02 + a12 * b12 + a22 * b22))
    d0, d1, d2 = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
    t = [a00 * d0 + a10 * d1 + a20 * d2, a01 * d0 + a11 * d1 + a21 * d2,
         a02 * d0 + a12 * d1 + a22 * d2]
    return ha, hb, rot, t, rot_a


class Decision(NamedTuple):
    """Stage 2 of one pair: its frame and the separating-axis decision by the tie rule. The
    region labeller of the learned predictors computes it, and :func:`answer_one` finishes the
    exact answer from it without deciding again."""

    frame: tuple  # (ha, hb, rot, t, rot_a, scale): half-extents, B in A's frame, A's rotation
    colliding: bool
    axis: int  # 0-14 (models.contacts), the contact axis
    normal: list  # 3 floats, A's frame, from A towards B
    depth: float  # metres, the axis overlap
    edge: tuple | None  # (point, feature_a, feature_b) of an edge-edge contact, else None


def decide_one(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b) -> Decision:
    """The :class:`Decision` of one validated pair (arguments as :func:`box_box_one`)."""
    ha, hb, rot, t, rot_a = relative_frame(size_a, position_a, quaternion_a, size_b,
                                           position_b, quaternion_b)
    scale = max(ha) + max(hb)
    return Decision((ha, hb, rot, t, rot_a, scale), *contact_axis(ha, hb, rot, t, scale))


def box_box_one(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """Exact contact of one validated pair; returns a one-row `Contacts`.

    Parameters are lists of floats, already validated: sizes (3,) > 0, positions (3,), unit
    quaternions (4,) (w, x, y, z); see :func:`single_pair`.
    """
    decision = decide_one(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    return answer_one(decision, position_a, position_b)


def answer_one(decision: Decision, position_a, position_b):
    """Stage 3 of one pair from its :class:`Decision`: the one-row `Contacts`."""
    ha, hb, rot, t, rot_a, scale = decision.frame
    _, colliding, axis, normal, depth, edge = decision
    code, feature_a, feature_b = ct.NONE, bf.NO_FEATURE, bf.NO_FEATURE
    manifold = []
    point, pressure = None, 0.0
    if colliding and axis < 6:
        manifold, point, region_depth, code, feature_a, feature_b, pressure = _face_rows(
            ha, hb, rot, t, axis, scale)
        if region_depth is not None and region_depth < depth - REGION_DEPTH_TOL_REL * scale:
            depth = region_depth
    elif colliding:
        point, feature_a, feature_b = edge
        manifold, code = [(point, depth)], ct.EDGE_EDGE
    return _result(colliding, normal, depth, point, code, feature_a, feature_b, axis, manifold,
                   rot_a, position_a, position_b, pressure)


def reference_view(ha, hb, rot, t, axis):
    """``(h_ref, h_inc, R_ri, t_ri)``: the incident box seen from the reference box of a face
    axis (A's for axes 0-2, B's for 3-5)."""
    if axis < 3:
        return ha, hb, rot, t
    rot_t = _transpose(rot)
    return hb, ha, rot_t, [-v for v in apply(rot_t, t)]


def _face_rows(ha, hb, rot, t, axis, scale):
    """Face-axis contact of one pair: manifold, point in A's frame, the region's depth (None if
    empty), type and features."""
    ref_is_b = axis >= 3
    points, point, depth, inc, rank, ref_face, pressure = _face_contact(
        *reference_view(ha, hb, rot, t, axis), axis % 3, scale)
    if ref_is_b:
        points = [([t[r] + dot(rot[r], p) for r in range(3)], d) for p, d in points]
        point = [t[r] + dot(rot[r], point) for r in range(3)]
        return points, point, depth, FACE_INC_CODES[rank], inc, ref_face, pressure
    return points, point, depth, FACE_REF_CODES[rank], ref_face, inc, pressure


def _result(colliding, normal, depth, point, code, feature_a, feature_b, axis, manifold,
            rot_a, pa, pb, pressure=0.0):
    """Map one pair's A-frame answer to the world frame as a one-row `Contacts`.

    All floats go into one array and all small integers into another, whose views become the
    fields: two allocations instead of a dozen (NumPy's per-call cost dominates at N = 1).
    """
    if point is None:
        world_point = [0.5 * (pa[k] + pb[k]) for k in range(3)]
    else:
        world_point = [pa[r] + dot(rot_a[r], point) for r in range(3)]
    floats = apply(rot_a, normal) + world_point + [depth]
    for p, d in manifold:
        floats.extend([pa[r] + dot(rot_a[r], p) for r in range(3)])
    floats.extend(_PADDING[: 3 * (ct.MAX_MANIFOLD_POINTS - len(manifold))])
    floats.extend([d for _, d in manifold])
    floats.extend(_PADDING[: ct.MAX_MANIFOLD_POINTS - len(manifold)])
    floats.append(1.0)
    return ct.Contacts.one_row(floats, [code, feature_a, feature_b, axis, len(manifold)],
                               colliding, "exact", pressure)
