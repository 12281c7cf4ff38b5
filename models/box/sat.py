"""Separating-axis test for N box pairs, in A's local frame.

Stage 2 of the exact solver (see :mod:`impactnet.models.box.exact`). Box A is centred at the origin
with
identity orientation; box B has centre ``t`` and rotation ``R`` (B's axes as the columns of R).

The 15 candidate axes are A's face normals (axis ids 0-2), B's face normals (3-5) and the
cross products of A's edge direction i with B's edge direction j (``6 + 3 i + j``). Along a
unit axis u the two boxes overlap by ``r_A(u) + r_B(u) - |t . u|``; the boxes intersect iff
every axis overlaps, and the axis of least overlap gives the contact normal and depth.

Degenerate cross axes (edges within :data:`EDGE_SKEW_TOL_REL` of parallel) are skipped: for
parallel edges the face axes already complete the test, and the overlap along any direction
is never below the true penetration depth, so an imprecise near-parallel axis can only
overestimate and lose; skipping it costs at most the skew times the box size.

Tie rule between face and edge axes. A cross axis that points almost along a face normal
describes the same contact as that face (stacking with a tiny tilt: A's top edge x B's bottom
edge is within the tilt of the vertical), and its edge-edge answer (one crossing point, up to
half an edge from the overlap's centre) is ill-conditioned there. So:

1. *Angle band.* A cross axis within :data:`FACE_AXIS_ANGLE_TOL` of the normal of the face
   axis of least overlap never becomes the contact axis (it still counts for separation).
2. *Depth gain.* Among the others, the shallowest cross axis wins only if it is shallower than
   the shallowest face axis by more than :data:`DEPTH_GAIN_TOL_REL` times the pair's scale;
   a cross axis of rule 1 counts as that face, with its own (smaller) overlap.
3. *Real crossing.* An edge-edge contact is reported only where the closest points of the two
   supporting edges lie inside both segments (:data:`EDGE_INSIDE_TOL_REL`); otherwise the face
   axis answers (:func:`impactnet.models.box.exact.contact_axes`).

Among face axes within :data:`TIE_TOL_REL` of the least overlap the lowest id wins (A before B,
x before y before z); there is no percentage bias.

Worst case of the rule (backed by ``tests/models/box/test_exact_tie_rule.py``). The SAT's least
overlap over the 15 axes is the true penetration depth ``c`` along the least-penetration axis
``u``. When the rule answers with a face axis ``n`` instead:

* the normal: by rule 1, a rejected ``u`` lies within ``phi = FACE_AXIS_ANGLE_TOL`` of ``n``
  itself; by rule 2 the face may win over a cross axis at any angle, but only when both are
  equally deep to ``DEPTH_GAIN_TOL_REL`` of the size (a tie);
* the depth: a face contact reports the SAT overlap along ``n`` unless the deepest point of its
  pressure region below the reference face is shallower (the incident box's deepest vertex
  hangs beyond the reference face), then that point's depth (:mod:`impactnet.models.box.exact`,
  :data:`impactnet.models.box.pressure.REGION_DEPTH_TOL_REL`). It lies between ``c`` and the overlap
  along
  ``n``; the overlaps along two unit axes differ by at most
  ``|u - n| (rho_A + rho_B + |t|) <= 2 phi (rho_A + rho_B)`` (``rho``: a box's half diagonal),
  so the depth exceeds ``c`` by at most that bound, 7 cm for two 2 m cubes, and by at most
  4.4e-7 of the pair's scale on 560,000 first-contact poses of every size and orientation
  family (measured in the test);
* rule 3 applies only at ties: for the exact least overlap, the closest points of the crossing
  edges lie inside both edges (the nearest facet of the Minkowski difference contains the
  origin's projection).

Layout: the vectorised solver works on columns (:mod:`impactnet.models.box.local_frame`); overlaps
are
(15, m). Only the chosen axis is kept as a vector: :func:`unit_axis` recomputes it from its
id with the same formulas. Every formula sums its terms in the order of
:mod:`impactnet.models.box.exact_one`, so both paths agree to the last bit. (A row-major (n, 15)
overlap table for tests and data work is :func:`impactnet.models.geometry.approach.axis_overlaps`.)
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box.local_frame import LocalPose

#: Relative tolerance (x pair scale, metres) for ties among face axes: rounding of an overlap
#: is a few ulps of the scale, so differences below this are noise, not geometry.
TIE_TOL_REL = 1e-12
#: Angle band (radians) of rule 1: a cross axis closer than this to the least-overlap face's
#: normal is that face's contact seen through a tilt. 1e-2 rad covers the stacking tilts of a
#: crane (a container set down a fraction of a degree out of level; MuJoCo's box-box uses a
#: wider band, |cos| > 0.99, with a 5 % depth bias on top). A genuine edge-on-edge contact
#: (crossed or skewed edges, each box presenting an edge) has its cross axis tens of degrees
#: from the face normals. A cross axis lies in the plane perpendicular to its edge of A, so on
#: uniformly random poses it falls in the band with probability about 1.3 phi (1.3 %); its
#: face answer is then within phi of it and as deep as the region it touches.
FACE_AXIS_ANGLE_TOL = 1e-2
#: cos(FACE_AXIS_ANGLE_TOL): the band is tested on the cosine of the angle to the face normal.
FACE_AXIS_COS_TOL = float(np.cos(FACE_AXIS_ANGLE_TOL))
#: Depth gain (x pair scale, metres) of rule 2: a cross axis must be shallower than the best
#: face axis by more than this to win. Far above the overlaps' rounding (1e-16 of the scale)
#: and far below any depth a simulator resolves; two features touching within it are a tie.
DEPTH_GAIN_TOL_REL = 1e-9
#: Slack (x pair scale, metres) of rule 3: a closest point this far past an edge's end still
#: counts as inside (a vertex lying on an edge is both answers at once).
EDGE_INSIDE_TOL_REL = 1e-9
#: Relative tolerance (x pair scale) under which two boxes still count as touching: a pair
#: placed exactly in contact computes an overlap of +-few ulps and must not flicker.
CONTACT_TOL_REL = 1e-12
#: Scale-aware parallel-edge test: a cross axis is skipped when the skew of the two edges
#: (sine of their angle) times the longer edge length is below this fraction of the pair's
#: scale, i.e. when the edges' misalignment over their length is rounding noise.
EDGE_SKEW_TOL_REL = 1e-12
#: Overlap assigned to skipped axes: they neither separate nor win.
SKIPPED_AXIS_OVERLAP = np.inf
#: Axis ids 0-2 as a column, to compare a per-row axis with every component at once.
_AXES = np.arange(3)[:, None]


def _near_entries() -> np.ndarray:
    """For face axis f (column) and cross axis (i, j) (row ``3 i + j``): the entry id ``3 row +
    col`` of R whose size is ``|cos| x |e_i x b_j|`` between the two axes, 9 where the cross
    axis is perpendicular to the face normal (see :func:`_near_face`)."""
    table = np.full((9, 6), 9)
    for i, j, f in np.ndindex(3, 3, 6):
        if f < 3 and f != i:
            table[3 * i + j, f] = 3 * (3 - i - f) + j  # R[o, j] = b_j[o], o the third A axis
        elif f >= 3 and f - 3 != j:
            table[3 * i + j, f] = 3 * i + (3 - j - (f - 3))  # R[i, o], o the third B axis
    return table


_NEAR_ENTRY = _near_entries()


def sign_nonnegative(x: np.ndarray) -> np.ndarray:
    """Sign with ties at zero resolved to +1 (deterministic orientation of axes)."""
    return np.where(x >= 0.0, 1.0, -1.0)


def _face_overlaps(pose: LocalPose, over: np.ndarray) -> None:
    """Overlaps along the 6 face normals (ids 0-5), written into ``over[0:6]``."""
    (a0, a1, a2), (b0, b1, b2) = pose.ha, pose.hb
    q = np.abs(pose.r)
    over[0:3] = pose.ha + q[0::3] * b0 + q[1::3] * b1 + q[2::3] * b2 - np.abs(pose.t)
    over[3:6] = pose.hb + q[0:3] * a0 + q[3:6] * a1 + q[6:9] * a2 - np.abs(pose.tb)


def _cross_overlaps(pose: LocalPose, over: np.ndarray, sines: np.ndarray) -> None:
    """Overlaps along the 9 edge-edge cross products (ids 6-14), written into ``over[6:15]``,
    and their lengths before normalisation ``|e_i x b_j|`` into ``sines``.

    ``e_i x b_j`` has components ``-b_j[q]`` at p and ``b_j[p]`` at q (p, q = i + 1, i + 2
    mod 3) and 0 at i; the zero terms of the scalar path's sums are exact and left out. The
    three axes of one i are computed together, as (3 j, m) arrays.
    """
    ha, hb, r, t = pose.ha, pose.hb, pose.r, pose.t
    skew_tol = EDGE_SKEW_TOL_REL * pose.scale
    square = r * r
    for i in range(3):
        p, q = (i + 1) % 3, (i + 2) % 3
        r_p, r_q = r[3 * p:3 * p + 3], r[3 * q:3 * q + 3]  # row p, q of R: b_j[p], b_j[q]
        sine = sines[3 * i:3 * i + 3]
        np.sqrt(square[3 * p:3 * p + 3] + square[3 * q:3 * q + 3], out=sine)
        valid = sine * 2.0 * np.maximum(ha[i], hb) > skew_tol
        divisor = sine if valid.all() else np.where(valid, sine, 1.0)
        u_p, u_q = -(r_q / divisor), r_p / divisor  # unit axis components at p and q
        dots = u_p[:, None] * r_p + u_q[:, None] * r_q  # u_j . b_k, (3 j, 3 k, m)
        radius_b = hb * np.abs(dots)
        radius_b = radius_b[:, 0] + radius_b[:, 1] + radius_b[:, 2]
        radius_a = ha[p] * np.abs(u_p) + ha[q] * np.abs(u_q)
        cross = over[6 + 3 * i:9 + 3 * i]
        np.subtract(radius_a + radius_b, np.abs(u_p * t[p] + u_q * t[q]), out=cross)
        if divisor is not sine:
            cross[~valid] = SKIPPED_AXIS_OVERLAP


def overlap_columns(pose: LocalPose) -> tuple[np.ndarray, np.ndarray]:
    """Overlap of the two boxes along each of the 15 axes, for m pairs in columns.

    Parameters
    ----------
    pose : LocalPose
        The pairs in A's frame (metres).

    Returns
    -------
    overlap : ndarray, shape (15, m)
        Overlap (metres) along each axis; negative where the axis separates, +inf where
        a degenerate cross axis was skipped.
    sines : ndarray, shape (9, m)
        ``|e_i x b_j|`` of each cross axis (ids 6-14) before normalisation, for
        :func:`choose_axis`'s angle band.
    """
    over = np.empty((15, pose.data.shape[1]))
    sines = np.empty((9, pose.data.shape[1]))
    _face_overlaps(pose, over)
    _cross_overlaps(pose, over, sines)
    return over, sines


def _first_true(flags: np.ndarray) -> np.ndarray:
    """Index of the first True row of ``flags`` (k, m) per column (k if none), int8 (m,)."""
    index = np.full(flags.shape[1], flags.shape[0], np.int8)
    for k in range(flags.shape[0] - 1, -1, -1):
        index = np.where(flags[k], np.int8(k), index)
    return index


def _at(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``values[index[i], i]`` for values (k, m) and index (m,)."""
    m = values.shape[1]
    return np.take(values.reshape(-1), index * m + np.arange(m))


def _near_face(r: np.ndarray, sines: np.ndarray, face_axis: np.ndarray) -> np.ndarray:
    """Rule 1: which cross axes lie within the angle band of the face axis ``face_axis``.

    The unit cross axis ``u = e_i x b_j / s`` (``s = |e_i x b_j|``, ``sines``) has cosine
    ``|R[o, j]| / s`` with A's normal ``e_a`` (a != i; o the third axis of A) and ``|R[i, o]| / s``
    with B's normal ``b_b`` (b != j; o the third axis of B), and is perpendicular to ``e_i`` and
    ``b_j``; it is near when that cosine is at least ``cos(FACE_AXIS_ANGLE_TOL)``.

    Parameters
    ----------
    r : ndarray, shape (9, m)
        R row-major (see :class:`impactnet.models.box.local_frame.LocalPose`).
    sines : ndarray, shape (9, m)
    face_axis : ndarray of int, shape (m,)
        The face axis (0-5) of each pair.

    Returns
    -------
    ndarray of bool, shape (9, m)
    """
    entry = np.take(_NEAR_ENTRY, face_axis, axis=1)  # (9, m): R entry id, 9 for "never near"
    padded = np.concatenate((np.abs(r), np.zeros((1, r.shape[1]))))
    cosine_times_sine = np.take_along_axis(padded, entry, axis=0)
    return cosine_times_sine >= FACE_AXIS_COS_TOL * sines


def choose_axis(overlap: np.ndarray, sines: np.ndarray, r: np.ndarray, scale: np.ndarray):
    """Pick each pair's contact axis by least overlap and rules 1-2 of the tie rule.

    Parameters
    ----------
    overlap : ndarray, shape (15, m)
    sines : ndarray, shape (9, m)
        From :func:`overlap_columns`.
    r : ndarray, shape (9, m)
        B's rotation in A's frame, row-major.
    scale : ndarray, shape (m,)
        Pair scale (metres).

    Returns
    -------
    colliding : ndarray of bool, shape (m,)
        True where every axis overlaps (within :data:`CONTACT_TOL_REL`).
    axis : ndarray of int8, shape (m,)
        Contact axis for colliding pairs; the axis of largest separation otherwise.
    depth : ndarray, shape (m,)
        Overlap along the contact axis, clamped at 0 (metres); 0 for separated pairs.
    face_axis : ndarray of int8, shape (m,)
        The face axis that rule 3 falls back to where a cross axis won.
    face_depth : ndarray, shape (m,)
        Its overlap, clamped at 0 (metres).
    """
    tie = TIE_TOL_REL * scale
    face, cross = overlap[:6], overlap[6:]
    face_min = np.minimum.reduce(face)
    face_axis = _first_true(face <= face_min + tie)
    near = _near_face(r, sines, face_axis.astype(np.intp))
    eligible = np.where(near, SKIPPED_AXIS_OVERLAP, cross)
    cross_min = np.minimum.reduce(eligible)
    cross_axis = _first_true(eligible == cross_min) + np.int8(6)
    # a cross axis in the band is the face's own contact: it competes with the face's depth
    face_bar = np.minimum(face_min, np.minimum.reduce(np.where(near, cross,
                                                               SKIPPED_AXIS_OVERLAP)))
    use_cross = cross_min < face_bar - DEPTH_GAIN_TOL_REL * scale
    axis = np.where(use_cross, cross_axis, face_axis)
    face_depth = _at(face, face_axis.astype(np.intp))
    chosen = np.where(use_cross, cross_min, face_depth)
    any_cross = np.minimum.reduce(cross)
    colliding = np.minimum(face_min, any_cross) >= -CONTACT_TOL_REL * scale
    if not colliding.all():
        widest = _first_true(cross == any_cross) + np.int8(6)
        separating = np.where(face_min <= any_cross, _first_true(face == face_min), widest)
        axis = np.where(colliding, axis, separating)
    depth = np.where(colliding, np.maximum(chosen, 0.0), 0.0)
    face_depth = np.where(colliding, np.maximum(face_depth, 0.0), 0.0)
    return colliding, axis, depth, face_axis, face_depth


def unit_axis(pose: LocalPose, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis ``axis[i]`` of pair i, recomputed with the formulas of the overlaps.

    Parameters
    ----------
    pose : LocalPose
        m pairs in A's frame.
    axis : ndarray of int, shape (m,)
        Axis ids (0-14); a degenerate cross axis gives a finite, meaningless vector.

    Returns
    -------
    unit : ndarray, shape (3, m)
        The unit axis in A's frame, not oriented.
    projection : ndarray, shape (m,)
        ``unit . t``, the signed distance of B's centre along it (metres).
    """
    m = len(axis)
    k = axis.astype(np.intp)
    r, t = pose.r.reshape(-1), pose.t.reshape(-1)
    unit, projection = np.empty((3, m)), np.empty(m)
    rows = np.flatnonzero(k < 3)  # A's face normals: e_k
    unit[:, rows] = (k[rows] == _AXES).astype(np.float64)
    projection[rows] = np.take(t, k[rows] * m + rows)
    rows = np.flatnonzero((k >= 3) & (k < 6))  # B's face normals: column j of R
    j = k[rows] - 3
    unit[:, rows] = np.take(r, (3 * _AXES + j) * m + rows)
    projection[rows] = np.take(pose.tb.reshape(-1), j * m + rows)
    rows = np.flatnonzero(k >= 6)  # e_i x b_j, as in _cross_overlaps
    i, j = np.divmod(k[rows] - 6, 3)
    p, q = (i + 1) % 3, (i + 2) % 3
    b_p, b_q = np.take(r, (3 * p + j) * m + rows), np.take(r, (3 * q + j) * m + rows)
    sine = np.sqrt(b_p * b_p + b_q * b_q)
    sine = np.where(sine > 0.0, sine, 1.0)
    u_p, u_q = -(b_q / sine), b_p / sine
    projection[rows] = u_p * np.take(t, p * m + rows) + u_q * np.take(t, q * m + rows)
    unit[:, rows] = np.where(_AXES == i, 0.0, np.where(_AXES == p, u_p, u_q))
    return unit, projection


def oriented_normal(pose: LocalPose, axis: np.ndarray) -> np.ndarray:
    """Axis ``axis[i]`` of pair i oriented from A towards B, in A's frame, shape (3, m)."""
    unit, projection = unit_axis(pose, axis)
    return unit * sign_nonnegative(projection)
