"""Contact manifolds for N box pairs: face clipping and edge-edge closest points.

Stage 3 of the exact solver (see :mod:`impactnet.models.box.exact`).

Face axes. The box that owns the chosen face axis is the *reference* box; the other one is the
*incident* box. Everything happens in the reference box's frame, where the reference face is
the axis-aligned rectangle ``|u| <= h_u, |w| <= h_w`` in the plane ``x_axis = sign * h_axis``.
The incident face is the incident box's face most anti-parallel to the normal. Its clip
against the rectangle (the Sutherland-Hodgman result) is found in closed form
(:mod:`impactnet.models.box.clip`): the vertices of the intersection of a convex quad and a
rectangle are
(a) quad vertices inside the rectangle, (b) rectangle corners inside the quad, (c) crossings
of a quad edge with the interior of a rectangle edge. Coincidences within
:data:`SNAP_TOL_REL` are counted once, in that order of priority, so a stack of equal boxes
gives 4 points, not 8. Points above the reference plane (negative depth) are dropped; the
points where the incident face crosses the reference plane (depth 0) are not reported. Depths
are clamped at 0. The reported points lie on the mid-surface (moved by half their depth
towards the incident box), deepest first. The manifold is the contact *set*; the impact point
is the centre of pressure of the whole footprint (:mod:`impactnet.models.box.pressure`), which
involves up to
three incident faces and need not lie inside the manifold's hull.

The incident feature is named by how many of the incident face's vertices penetrate: one
vertex, two (an edge) or three or more (the face).

Edge axes. The supporting edge of A along +normal and of B along -normal; the contact point is
the midpoint of their closest points (clamped to the edges), and the contact is an edge-edge
one only where those points lie inside both edges (rule 3 of :mod:`impactnet.models.box.sat`).

Columns: quantities are (m,) arrays, vectors and matrices stacked as (3, m) and (9, m) (see
:mod:`impactnet.models.box.local_frame`). The face rows' quantities in the reference frame are read
from the
block by flat index (:class:`ReferenceFrame`), their coordinates taken in the cyclic order
(axis, u, w) with ``u, w = axis + 1, axis + 2 (mod 3)``. A face manifold is returned as
*entries*, one per manifold point (E in all), each naming its row and slot, so that no work
is spent on empty slots. Sums follow :mod:`impactnet.models.box.exact_one` term by term.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box import clip
from impactnet.models.box.local_frame import AxisChoice, matvec
from impactnet.models.box.sat import EDGE_INSIDE_TOL_REL, sign_nonnegative
from impactnet.models.geometry import box_features as bf

#: Relative tolerance (x pair scale, metres) under which two candidate manifold points, or a
#: point and a clip boundary, are the same: equal boxes stacked exactly produce coincident
#: candidates that differ only by rounding.
SNAP_TOL_REL = 1e-12
#: Quad vertices in cyclic order, as signs along the incident face's two in-plane axes.
QUAD_SIGNS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])

#: Axis ids 0-2 as a column, to compare a per-row axis with every component at once.
_AXES = np.arange(3)[:, None]
#: Bit weights of the x, y, z signs in a vertex id; of the two other axes j < l (by the edge's
#: axis, row) in an edge id.
_VERTEX_WEIGHTS = np.array([4, 2, 1])
_EDGE_WEIGHTS = np.array([[0, 2, 1], [2, 0, 1], [2, 1, 0]]).reshape(-1)


def _frame_tables():
    """Row ids into a LocalPose block of the reference-frame quantities, by case code.

    Tables are (entries, codes). Codes: ``3 flip + ref`` (flip = B owns the face, ref = the
    reference axis) for quantities along (axis, u, w) of the reference face; ``3 flip + k``
    (k = the incident face axis) for the incident half-extents along (k, p, q); and
    ``9 flip + 3 ref + k`` for the rotation, entry ``3 c + j`` = reference axis c (in the
    order axis, u, w), incident axis j (in the order k, p, q).
    """
    half_ref, centre, normal, half_inc = (np.empty((3, 6), int) for _ in range(4))
    rotation = np.empty((9, 18), int)
    for flip, axis, c in np.ndindex(2, 3, 3):
        code, cyclic = 3 * flip + axis, (axis + c) % 3
        half_ref[c, code] = (3 if flip else 0) + cyclic  # reference box: B if flipped
        centre[c, code] = (18 if flip else 15) + cyclic  # t, or R^T t (negated when read)
        normal[c, code] = 6 + (3 * c + axis if flip else 3 * axis + c)  # row `axis` of R_ri
        half_inc[c, code] = (0 if flip else 3) + cyclic  # incident box: A if flipped
    for flip, ref, k, c, j in np.ndindex(2, 3, 3, 3, 3):
        row, col = (ref + c) % 3, (k + j) % 3
        rotation[3 * c + j, 9 * flip + 3 * ref + k] = 6 + (3 * col + row if flip else
                                                           3 * row + col)
    return half_ref, centre, normal, half_inc, rotation


_HALF_REF_ROWS, _CENTRE_ROWS, _NORMAL_ROWS, _HALF_INC_ROWS, _ROTATION_ROWS = _frame_tables()


def _face_tables():
    """Row ids of the incident box's three faces, for :meth:`ReferenceFrame.faces`.

    ``axes`` (27, 6): entry ``9 k + 3 role + c`` = incident axis ``(k + role) % 3`` (role 0, 1,
    2: the face normal k and its in-plane axes p, q) along reference coordinate c (axis, u,
    w), by code ``3 flip + ref``. ``halves`` (9, 2): entry ``3 k + role`` = the incident
    half-extent along ``(k + role) % 3``, by flip.
    """
    axes, halves = np.empty((27, 6), int), np.empty((9, 2), int)
    for flip, ref, k, role, c in np.ndindex(2, 3, 3, 3, 3):
        axes[9 * k + 3 * role + c, 3 * flip + ref] = _ROTATION_ROWS[3 * c + (k + role) % 3,
                                                                    9 * flip + 3 * ref]
    for flip, k, role in np.ndindex(2, 3, 3):
        halves[3 * k + role, flip] = _HALF_INC_ROWS[(k + role) % 3, 3 * flip]
    return axes, halves


_FACE_AXES_ROWS, _FACE_HALF_ROWS = _face_tables()


class ReferenceFrame:
    """Face-axis pairs seen from the reference box, read from a LocalPose by flat index.

    The reference box is B where ``ref_is_b`` (then the roles of the half-extents swap, R is
    transposed and the incident centre is ``-R^T t``), else A; reference-frame coordinates
    are taken in the cyclic order (axis, u, w) of the reference face.

    Parameters
    ----------
    pose : impactnet.models.box.local_frame.LocalPose
        A block of pairs in A's frame.
    rows : ndarray of int, shape (m,)
        The face-axis pairs among them.
    ref_is_b : ndarray of bool, shape (m,)
    ref_axis : ndarray of int, shape (m,)
        Reference face axis (0-2) in the reference box.
    """

    def __init__(self, pose, rows, ref_is_b, ref_axis):
        self.flat, self.stride, self.rows = pose.data.reshape(-1), pose.data.shape[1], rows
        self.flip, self.ref_axis = ref_is_b, ref_axis
        self.code = 3 * ref_is_b + ref_axis

    def _gather(self, table, code):
        """Entries ``pose.data[table[e, code[i]], rows[i]]``, shape (entries, m)."""
        return np.take(self.flat, np.take(table * self.stride, code, axis=1) + self.rows)

    def half_ref(self):
        """Reference half-extents along (axis, u, w), (3, m) metres."""
        return self._gather(_HALF_REF_ROWS, self.code)

    def centre(self):
        """Incident centre along (axis, u, w), (3, m) metres."""
        value = self._gather(_CENTRE_ROWS, self.code)
        return np.where(self.flip, -value, value)

    def normal_row(self):
        """Row ``ref_axis`` of the incident axes (as columns) in the reference frame, (3, m)."""
        return self._gather(_NORMAL_ROWS, self.code)

    def rotation(self, k):
        """Incident axes k, p, q (columns) along (axis, u, w) (rows), (3, 3, m)."""
        return self._gather(_ROTATION_ROWS, 3 * self.code + k).reshape(3, 3, -1)

    def faces(self):
        """The incident box's axes and half-extents face by face.

        Returns ``axes`` (3 k, 3 role, 3 c, m): incident axis ``(k + role) % 3`` along the
        reference coordinates (axis, u, w), and ``halves`` (3 k, 3 role, m) (metres).
        """
        axes = self._gather(_FACE_AXES_ROWS, self.code).reshape(3, 3, 3, -1)
        return axes, self._gather(_FACE_HALF_ROWS, self.flip.astype(np.intp)).reshape(3, 3, -1)

    def half_inc(self, k):
        """Incident half-extents along k, p, q, (3, m) metres."""
        return self._gather(_HALF_INC_ROWS, 3 * self.flip + k)


def incident_quad(frame: ReferenceFrame):
    """The incident face's vertices in the reference frame, coordinates (axis, u, w).

    Returns
    -------
    vertices : ndarray, shape (4, 3, m)
        Quad vertices in cyclic order (signs :data:`QUAD_SIGNS` along the face's axes p, q).
    ref_sign : ndarray, shape (m,)
        Side (+-1) of the reference face, facing the incident box.
    k : ndarray of int, shape (m,)
        Incident face normal axis, in the incident box's frame.
    side : ndarray, shape (m,)
        Incident face side (+-1) along k.
    """
    t_ref = frame.centre()
    ref_sign = sign_nonnegative(t_ref[0])
    n_inc = ref_sign * frame.normal_row()
    size = np.abs(n_inc)
    k = np.where(size[1] > size[0], 1, 0)
    k = np.where(size[2] > np.maximum(size[0], size[1]), 2, k)
    rot = frame.rotation(k)
    h_k, h_p, h_q = frame.half_inc(k)
    side = -sign_nonnegative(AxisChoice(k).pick(n_inc))
    centre = t_ref + (side * h_k) * rot[:, 0]
    along_p, along_q = h_p * rot[:, 1], h_q * rot[:, 2]
    plus_p, minus_p = centre + along_p, centre - along_p
    vertices = np.empty((4,) + centre.shape)
    np.add(plus_p, along_q, out=vertices[0])
    np.add(minus_p, along_q, out=vertices[1])
    np.subtract(minus_p, along_q, out=vertices[2])
    np.subtract(plus_p, along_q, out=vertices[3])
    return vertices, ref_sign, k, side


def _stable_first_two(depth):
    """Indices of the deepest and the second deepest of 4 depths (4, m), ties to the lower."""
    late01, late23 = depth[1] > depth[0], depth[3] > depth[2]
    top01, top23 = np.maximum(depth[0], depth[1]), np.maximum(depth[2], depth[3])
    low01, low23 = np.minimum(depth[0], depth[1]), np.minimum(depth[2], depth[3])
    win01, win23 = late01.astype(np.intp), 2 + late23
    in01 = top01 >= top23
    first = np.where(in01, win01, win23)
    second = np.where(in01, np.where(low01 >= top23, 1 - win01, win23),
                      np.where(top01 >= low23, win01, 5 - win23))
    return first, second


def incident_feature(depth, k, side, tol):
    """Incident feature id and rank (1 vertex, 2 edge, 3 face) from the 4 vertex depths.

    The deepest vertex and the next one (stable order) name the edge; their sign vectors
    are ``side`` along k and :data:`QUAD_SIGNS` along p, q = k + 1, k + 2 (mod 3).
    """
    first, second = _stable_first_two(depth)
    touching = (depth >= -tol).sum(axis=0)
    p, q = (k + 1) % 3, (k + 2) % 3
    neg_k = side < 0
    neg_p, neg_q = (first == 1) | (first == 2), first >= 2  # QUAD_SIGNS < 0
    diff_p, diff_q = neg_p != ((second == 1) | (second == 2)), neg_q != (second >= 2)
    vertex = (bf.VERTEX_BASE + np.take(_VERTEX_WEIGHTS, k) * neg_k
              + np.take(_VERTEX_WEIGHTS, p) * neg_p + np.take(_VERTEX_WEIGHTS, q) * neg_q)
    along = np.where(diff_p & diff_q, np.minimum(p, q), np.where(diff_p, p, q))
    edge = (bf.EDGE_BASE + 4 * along + np.take(_EDGE_WEIGHTS, 3 * along + k) * neg_k
            + np.take(_EDGE_WEIGHTS, 3 * along + p) * neg_p
            + np.take(_EDGE_WEIGHTS, 3 * along + q) * neg_q)
    feature = np.where(touching >= 3, bf.face_id(k, neg_k),
                       np.where(touching == 2, edge, vertex))
    return feature, np.clip(touching, 1, 3)


def face_manifold(frame: ReferenceFrame, scale):
    """Clip the incident face against the reference face, for m face-axis contacts.

    Parameters
    ----------
    frame : ReferenceFrame
        The m pairs seen from their reference boxes.
    scale : ndarray, shape (m,)
        Pair scale (metres) for the tolerances.

    Returns
    -------
    points : ndarray, shape (3, E)
        Mid-surface manifold points in the reference frame (metres), one per entry.
    depths : ndarray, shape (E,)
        Their penetration depths (metres), clamped at 0 (a candidate kept within the snap
        tolerance above the plane is a touching point).
    rows, slots : ndarray of int, shape (E,)
        Row (0..m-1) and manifold slot (0 = deepest) of each entry, ordered by row, then slot.
    count : ndarray of int8, shape (m,)
    incident_feature : ndarray of int, shape (m,)
        Feature id in the incident box (vertex, edge or face).
    touching_rank : ndarray of int, shape (m,)
        1 vertex, 2 edge, 3 face: the kind of the incident feature.
    ref_face : ndarray of int, shape (m,)
        Face id of the reference face in the reference box.
    deepest : ndarray, shape (3, m)
        The incident face's deepest vertex clamped into the reference face, on the
        mid-surface, coordinates (axis, u, w): the point of a row whose pressure region is
        empty (:func:`impactnet.models.box.pressure.centre_of_pressure`).
    """
    tol = SNAP_TOL_REL * scale
    ref_axis = frame.ref_axis
    vertices, ref_sign, k, side = incident_quad(frame)
    height, half_u, half_w = frame.half_ref()
    depth = height - ref_sign * vertices[:, 0]
    candidates = clip.clip_candidates(vertices[:, 1], vertices[:, 2], depth, half_u, half_w,
                                      tol)
    rows, slots, (u, w, depths), count = clip.manifold_order(candidates)
    depths = np.maximum(depths, 0.0)
    normal = np.take(ref_sign * height, rows) - np.take(ref_sign * 0.5, rows) * depths
    points = from_reference(np.take(ref_axis, rows), normal, u, w)
    feature, rank = incident_feature(depth, k, side, tol)
    first = _stable_first_two(depth)[0]
    corner = np.take_along_axis(vertices, first[None, None, :], axis=0)[0]  # (3, m)
    deepest_depth = np.maximum(height - ref_sign * corner[0], 0.0)
    deepest = np.array([ref_sign * height - ref_sign * 0.5 * deepest_depth,
                        np.minimum(np.maximum(corner[1], -half_u), half_u),
                        np.minimum(np.maximum(corner[2], -half_w), half_w)])
    return (points, depths, rows, slots, count, feature, rank,
            bf.face_id(ref_axis, ref_sign < 0), deepest)


def from_reference(axis, along, u, w) -> np.ndarray:
    """Points (3, m) in (x, y, z) from coordinates ``along`` the reference axis and ``u``,
    ``w`` (the next two axes, cyclic), each (m,)."""
    points = np.empty((3, len(axis)))
    for c in range(3):
        points[c] = np.where(axis == c, along, np.where(axis == (c + 2) % 3, u, w))
    return points


#: Contact type of a face-axis contact by the incident feature's rank (1 vertex, 2 edge,
#: 3 face), the reference face being A's (FACE_REF_CODES) or B's (FACE_INC_CODES).
FACE_REF_CODES = np.array([0, ct.FACE_VERTEX, ct.FACE_EDGE, ct.FACE_FACE], np.int8)
FACE_INC_CODES = np.array([0, ct.VERTEX_FACE, ct.EDGE_FACE, ct.FACE_FACE], np.int8)


def face_labels(ref_is_b, incident, rank, ref_face):
    """(type code, feature of A, feature of B) of face-axis contacts, each (m,).

    ``ref_is_b`` (m,) bool: the reference face is B's; ``incident`` and ``rank`` (1 vertex,
    2 edge, 3 face): the incident feature; ``ref_face``: the reference face id.
    """
    code = np.where(ref_is_b, FACE_INC_CODES[rank], FACE_REF_CODES[rank])
    return (code, np.where(ref_is_b, incident, ref_face),
            np.where(ref_is_b, ref_face, incident))


def edge_contact(pose, normal, axis):
    """Closest points of the supporting edges for m edge-edge contacts, in A's frame.

    Parameters
    ----------
    pose : impactnet.models.box.local_frame.LocalPose
        The m pairs in A's frame.
    normal : ndarray, shape (3, m)
        Unit normal from A towards B in A's frame.
    axis : ndarray of int, shape (m,)
        Cross axis ids (6-14).

    Returns
    -------
    point : ndarray, shape (3, m)
        Midpoint of the two closest points (the mid-surface point), A's frame (metres).
    edge_a, edge_b : ndarray of int, shape (m,)
        Feature ids of the two edges.
    inside : ndarray of bool, shape (m,)
        The unclamped closest points lie inside both edges (within
        :data:`impactnet.models.box.sat.EDGE_INSIDE_TOL_REL`): rule 3 of the tie rule
        (:mod:`impactnet.models.box.sat`).
    """
    i, j = (axis - 6) // 3, (axis - 6) % 3
    on_i, along_a, along_b = i == _AXES, AxisChoice(i), AxisChoice(j)
    r = pose.r
    # Edge centres: +-h along the other axes, the side of the normal's sign (ties to +).
    centre_a = np.where(on_i, 0.0, np.where(normal >= 0.0, pose.ha, -pose.ha))
    normal_in_b = r[0:3] * normal[0] + r[3:6] * normal[1] + r[6:9] * normal[2]
    local_b = np.where(j == _AXES, 0.0, np.where(normal_in_b >= 0.0, -pose.hb, pose.hb))
    centre_b = pose.t + matvec(r, local_b)
    dir_b = along_b.pick(r.reshape(3, 3, -1).transpose(1, 0, 2))  # column j of R
    offset = centre_b - centre_a
    cos = along_a.pick(dir_b)
    square = dir_b * dir_b
    sine2 = along_a.pick(np.array([square[1] + square[2], square[0] + square[2],
                                   square[0] + square[1]]))
    proj_a = along_a.pick(offset)
    proj_b = offset[0] * dir_b[0] + offset[1] * dir_b[1] + offset[2] * dir_b[2]
    safe = np.where(sine2 > 0, sine2, 1.0)
    reach_a, reach_b = along_a.pick(pose.ha), along_b.pick(pose.hb)
    s_free, t_free = (proj_a - cos * proj_b) / safe, (cos * proj_a - proj_b) / safe
    slack = EDGE_INSIDE_TOL_REL * pose.scale
    inside = ((sine2 > 0) & (np.abs(s_free) <= reach_a + slack)
              & (np.abs(t_free) <= reach_b + slack))
    s = np.minimum(np.maximum(s_free, -reach_a), reach_a)
    t = np.minimum(np.maximum(t_free, -reach_b), reach_b)
    point = 0.5 * (np.where(on_i, s, centre_a) + centre_b + t * dir_b)
    return point, _edge_id(i, normal < 0), _edge_id(j, normal_in_b >= 0), inside


def _edge_id(axis, negative):
    """Edge id along ``axis`` (m,) from the per-axis negative signs (3, m) of its centre."""
    return bf.edge_id(axis, np.where(axis == 0, negative[1], negative[0]),
                      np.where(axis == 2, negative[1], negative[2]))
