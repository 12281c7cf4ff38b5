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
from impactnet.models.box.sat import (
    CONTACT_TOL_REL,
    DEPTH_GAIN_TOL_REL,
    EDGE_INSIDE_TOL_REL,
    EDGE_SKEW_TOL_REL,
    FACE_AXIS_COS_TOL,
    TIE_TOL_REL,
)
from impactnet.models.box.scalar_inputs import single_pair  # noqa: F401  (re-exported: the N = 1 entry)
from impactnet.models.geometry import box_features as bf
from impactnet.models.geometry.rotations import quaternion_matrix

_QUAD = [tuple(s) for s in QUAD_SIGNS.tolist()]
# impactnet.models.box.manifold's tables as Python ints (the scalar path avoids NumPy scalars).
FACE_REF_CODES = tuple(FACE_REF_CODES_ARRAY.tolist())
FACE_INC_CODES = tuple(FACE_INC_CODES_ARRAY.tolist())
_PADDING = [0.0] * (3 * ct.MAX_MANIFOLD_POINTS)



def sgn(x: float) -> float:
    return 1.0 if x >= 0.0 else -1.0


def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _quat_matrix(q):
    """Rotation matrix (rows) of a unit quaternion (w, x, y, z)."""
    m = quaternion_matrix(*q)
    return m[0:3], m[3:6], m[6:9]


def overlaps(ha, hb, rot, t, scale):
    """Overlap along the 15 axes, the unit axes and the cross axes' sines to the nearest face
    normal, as in :func:`impactnet.models.box.sat.overlap_columns`."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rot
    a0, a1, a2 = ha
    b0, b1, b2 = hb
    t0, t1, t2 = t
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = (abs(r00), abs(r01), abs(r02), abs(r10),
                                                   abs(r11), abs(r12), abs(r20), abs(r21),
                                                   abs(r22))
    over = [
        a0 + q00 * b0 + q01 * b1 + q02 * b2 - abs(t0),
        a1 + q10 * b0 + q11 * b1 + q12 * b2 - abs(t1),
        a2 + q20 * b0 + q21 * b1 + q22 * b2 - abs(t2),
        b0 + q00 * a0 + q10 * a1 + q20 * a2 - abs(r00 * t0 + r10 * t1 + r20 * t2),
        b1 + q01 * a0 + q11 * a1 + q21 * a2 - abs(r01 * t0 + r11 * t1 + r21 * t2),
        b2 + q02 * a0 + q12 * a1 + q22 * a2 - abs(r02 * t0 + r12 * t1 + r22 * t2),
    ]
    cols = ((r00, r10, r20), (r01, r11, r21), (r02, r12, r22))
    axes = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), cols[0], cols[1], cols[2]]
    sines = []
    skew_tol = EDGE_SKEW_TOL_REL * scale
    for i in range(3):
        for j in range(3):
            x, y, z = cols[j]
            if i == 0:
                c0, c1, c2 = 0.0, -z, y
            elif i == 1:
                c0, c1, c2 = z, 0.0, -x
            else:
                c0, c1, c2 = -y, x, 0.0
            sine = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            if not sine * 2.0 * max(ha[i], hb[j]) > skew_tol:
                over.append(math.inf)
                axes.append((0.0, 0.0, 0.0))
                sines.append(sine)
                continue
            u0, u1, u2 = c0 / sine, c1 / sine, c2 / sine
            radius_b = (b0 * abs(u0 * r00 + u1 * r10 + u2 * r20)
                        + b1 * abs(u0 * r01 + u1 * r11 + u2 * r21)
                        + b2 * abs(u0 * r02 + u1 * r12 + u2 * r22))
            over.append(a0 * abs(u0) + a1 * abs(u1) + a2 * abs(u2) + radius_b
                        - abs(u0 * t0 + u1 * t1 + u2 * t2))
            axes.append((u0, u1, u2))
            sines.append(sine)
    return over, axes, sines


def _near_face(rot, sine, i, j, face_axis):
    """Rule 1 of :func:`impactnet.models.box.sat.choose_axis` for cross axis (i, j) (see
    :func:`impactnet.models.box.sat._near_face`)."""
    if face_axis < 3:
        if face_axis == i:
            return False
        entry = abs(rot[3 - i - face_axis][j])
    else:
        if face_axis - 3 == j:
            return False
        entry = abs(rot[i][3 - j - (face_axis - 3)])
    return entry >= FACE_AXIS_COS_TOL * sine


def choose_axis(over, sines, rot, scale):
    """Colliding flag, axis and face axis (rule 3's fallback), with rules 1-2 of the tie rule
    of :func:`impactnet.models.box.sat.choose_axis`."""
    tie = TIE_TOL_REL * scale
    face_min = min(over[:6])
    face_axis = next(k for k in range(6) if over[k] <= face_min + tie)
    colliding = min(over) >= -CONTACT_TOL_REL * scale
    gain = DEPTH_GAIN_TOL_REL * scale
    if min(over[6:]) >= face_min - gain:  # no cross axis can win: rule 1 need not be asked
        return colliding, (face_axis if colliding else over.index(min(over))), face_axis
    near = [_near_face(rot, sines[c], c // 3, c % 3, face_axis) for c in range(9)]
    eligible = [math.inf if n else over[6 + c] for c, n in enumerate(near)]
    cross_min = min(eligible)
    cross_axis = 6 + eligible.index(cross_min)
    face_bar = min(face_min, min([over[6 + c] if n else math.inf for c, n in enumerate(near)]))
    axis = cross_axis if cross_min < face_bar - gain else face_axis
    return colliding, (axis if colliding else over.index(min(over))), face_axis


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
    centre, depth = centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis, scale, fallback)
    return points, centre, depth, feature, rank, bf.FACE_BASE + 2 * ref_axis + (ref_sign < 0)


def edge_contact(ha, hb, rot, t, normal, axis):
    """Mid-point of the supporting edges' closest points, the two edge ids, and whether the
    closest points lie inside both edges (rule 3 of :mod:`impactnet.models.box.sat`)."""
    i, j = (axis - 6) // 3, (axis - 6) % 3
    sign_a = [sgn(v) for v in normal]
    centre_a = [0.0 if k == i else ha[k] * sign_a[k] for k in range(3)]
    cols = [(rot[0][c], rot[1][c], rot[2][c]) for c in range(3)]
    sign_b = [-sgn(dot(cols[k], normal)) for k in range(3)]
    local_b = [0.0 if k == j else hb[k] * sign_b[k] for k in range(3)]
    centre_b = [t[r] + dot(rot[r], local_b) for r in range(3)]
    dir_a = [1.0 if k == i else 0.0 for k in range(3)]
    dir_b = cols[j]
    offset = [centre_b[k] - centre_a[k] for k in range(3)]
    cos = dir_b[i]
    cx = (dir_a[1] * dir_b[2] - dir_a[2] * dir_b[1], dir_a[2] * dir_b[0] - dir_a[0] * dir_b[2],
          dir_a[0] * dir_b[1] - dir_a[1] * dir_b[0])
    sine2 = dot(cx, cx)
    proj_a, proj_b = offset[i], dot(offset, dir_b)
    safe = sine2 if sine2 > 0 else 1.0
    s_free, r_free = (proj_a - cos * proj_b) / safe, (cos * proj_a - proj_b) / safe
    slack = EDGE_INSIDE_TOL_REL * (max(ha) + max(hb))
    inside = sine2 > 0 and abs(s_free) <= ha[i] + slack and abs(r_free) <= hb[j] + slack
    s = min(max(s_free, -ha[i]), ha[i])
    r = min(max(r_free, -hb[j]), hb[j])
    point = [0.5 * (centre_a[k] + s * dir_a[k] + centre_b[k] + r * dir_b[k]) for k in range(3)]

    def edge(axis_, signs):
        j_, l_ = (1, 2) if axis_ == 0 else ((0, 2) if axis_ == 1 else (0, 1))
        return bf.EDGE_BASE + 4 * axis_ + 2 * (signs[j_] < 0) + (signs[l_] < 0)

    return point, edge(i, sign_a), edge(j, sign_b), inside


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
    point = None
    if colliding and axis < 6:
        manifold, point, region_depth, code, feature_a, feature_b = _face_rows(ha, hb, rot, t,
                                                                              axis, scale)
        if region_depth is not None and region_depth < depth - REGION_DEPTH_TOL_REL * scale:
            depth = region_depth
    elif colliding:
        point, feature_a, feature_b = edge
        manifold, code = [(point, depth)], ct.EDGE_EDGE
    return _result(colliding, normal, depth, point, code, feature_a, feature_b, axis, manifold,
                   rot_a, position_a, position_b)


def contact_axis(ha, hb, rot, t, scale):
    """``(colliding, axis, normal, depth, edge)`` of one pair in A's frame, by the tie rule
    (:func:`impactnet.models.box.exact.contact_axes`); ``edge`` is ``(point, feature_a, feature_b)``
    of an
    edge-edge contact, else None."""
    over, axes, sines = overlaps(ha, hb, rot, t, scale)
    colliding, axis, face_axis = choose_axis(over, sines, rot, scale)
    u = axes[axis]
    normal = [v * sgn(dot(u, t)) for v in u]
    edge = None
    if colliding and axis >= 6:
        point, feature_a, feature_b, inside = edge_contact(ha, hb, rot, t, normal, axis)
        if inside:
            edge = (point, feature_a, feature_b)
        else:  # rule 3: the edges do not really cross, the face axis answers
            axis = face_axis
            u = axes[axis]
            normal = [v * sgn(dot(u, t)) for v in u]
    depth = max(over[axis], 0.0) if colliding else 0.0
    return colliding, axis, normal, depth, edge


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
    points, point, depth, inc, rank, ref_face = _face_contact(
        *reference_view(ha, hb, rot, t, axis), axis % 3, scale)
    if ref_is_b:
        points = [([t[r] + dot(rot[r], p) for r in range(3)], d) for p, d in points]
        point = [t[r] + dot(rot[r], point) for r in range(3)]
        return points, point, depth, FACE_INC_CODES[rank], inc, ref_face
    return points, point, depth, FACE_REF_CODES[rank], ref_face, inc


def _result(colliding, normal, depth, point, code, feature_a, feature_b, axis, manifold,
            rot_a, pa, pb):
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
                               colliding, "exact")
