"""The separating-axis test of one pair in plain Python floats (the N = 1 mirror of
:mod:`impactnet.models.box.sat`): the 15 overlaps, the tie rule (rules 1-3, documented there)
and the edge-edge closest points. Same formulas and summation order as the batch path, so the
two agree bit for bit (tested).
"""
from __future__ import annotations

import math

from impactnet.models.box.sat import (
    CONTACT_TOL_REL,
    DEPTH_GAIN_TOL_REL,
    EDGE_INSIDE_TOL_REL,
    EDGE_SKEW_TOL_REL,
    FACE_AXIS_COS_TOL,
    TIE_TOL_REL,
)
from impactnet.models.geometry import box_features as bf


def sgn(x: float) -> float:
    return 1.0 if x >= 0.0 else -1.0


def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


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
