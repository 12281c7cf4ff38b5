"""The box solver's axis decisions redone with plain NumPy, and their margins (not a test module).

For N box pairs, row-major, in A's frame: the 15 separating-axis overlaps, the contact / no
contact decision, and the tie rule of :mod:`impactnet.models.box.sat` (face band, rule 1's
angle band, rule 2's depth gain, rule 3's real crossing, the most separating axis, the normal's
orientation, skipped parallel edges). Each decision's margin is the distance of the compared
quantity from its threshold; the recorder checks that these decisions give the solver's axis on
every row not borderline, so that the margins describe the solver's own rule.

Own code on purpose: it reads no solver stage, only its constants (:mod:`tests.golden.rule`)
and the quaternion convention of :mod:`impactnet.models.geometry.rotations`, so it survives the
switch to compiled kernels.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.geometry.rotations import quaternion_to_matrix
from tests.golden import rule

#: The cross axis ids (6 + 3 i + j) as (i, j) pairs.
CROSS_IJ = [(i, j) for i in range(3) for j in range(3)]


@dataclass
class Local:
    """N pairs in A's frame (metres): half-extents ``ha``, ``hb`` (n, 3), ``r`` (n, 3, 3) with
    B's axes as columns, ``t`` (n, 3) B's centre, ``scale`` (n,) the sum of the largest
    half-extents, ``reach`` (n,) ``1 + |p_B - p_A| / scale``."""

    ha: np.ndarray
    hb: np.ndarray
    r: np.ndarray
    t: np.ndarray
    scale: np.ndarray
    reach: np.ndarray


def local_pairs(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b) -> Local:
    """:class:`Local` of N pairs given as the solver's six (n, 3|4) inputs."""
    qa = quaternion_a / np.linalg.norm(quaternion_a, axis=1, keepdims=True)
    qb = quaternion_b / np.linalg.norm(quaternion_b, axis=1, keepdims=True)
    rot_a, rot_b = quaternion_to_matrix(qa), quaternion_to_matrix(qb)
    offset = position_b - position_a
    ha, hb = 0.5 * size_a, 0.5 * size_b
    scale = ha.max(axis=1) + hb.max(axis=1)
    return Local(ha, hb, np.einsum("nki,nkj->nij", rot_a, rot_b),
                 np.einsum("nki,nk->ni", rot_a, offset), scale,
                 1.0 + np.linalg.norm(offset, axis=1) / scale)


def cross_units(r: np.ndarray):
    """Unit cross axes ``e_i x b_j / s`` (n, 9, 3), their lengths ``s`` (n, 9); NaN-free (a
    zero-length axis gets a zero vector)."""
    n = len(r)
    units, sines = np.zeros((n, 9, 3)), np.zeros((n, 9))
    for c, (i, j) in enumerate(CROSS_IJ):
        p, q = (i + 1) % 3, (i + 2) % 3
        s = np.sqrt(r[:, p, j] ** 2 + r[:, q, j] ** 2)
        safe = np.where(s > 0.0, s, 1.0)
        units[:, c, p], units[:, c, q] = -r[:, q, j] / safe, r[:, p, j] / safe
        sines[:, c] = s
    return units, sines


def overlaps(pose: Local):
    """Overlaps (metres) along the 15 axes, unskipped (n, 15); the skip test's margin terms.

    Returns ``(over, skipped, skew, units, sines)``: ``skipped`` (n, 9) the cross axes the
    solver skips, ``skew`` (n, 9) ``2 s max(ha_i, hb_j)`` (metres), compared with
    ``EDGE_SKEW_TOL_REL x scale``.
    """
    ha, hb, r, t = pose.ha, pose.hb, pose.r, pose.t
    ar = np.abs(r)
    face_a = ha + np.einsum("nij,nj->ni", ar, hb) - np.abs(t)
    tb = np.einsum("nij,ni->nj", r, t)
    face_b = hb + np.einsum("nij,ni->nj", ar, ha) - np.abs(tb)
    units, sines = cross_units(r)
    radius_a = np.einsum("nck,nk->nc", np.abs(units), ha)
    radius_b = np.einsum("nck,nk->nc", np.abs(np.einsum("nci,nik->nck", units, r)), hb)
    cross = radius_a + radius_b - np.abs(np.einsum("nci,ni->nc", units, t))
    i_of, j_of = np.array(CROSS_IJ).T
    skew = 2.0 * sines * np.maximum(ha[:, i_of], hb[:, j_of])
    skipped = skew <= rule.EDGE_SKEW_TOL_REL * pose.scale[:, None]
    cross = np.where(sines > 0.0, cross, np.inf)
    return np.concatenate([face_a, face_b, cross], axis=1), skipped, skew, units, sines


def band_products(r: np.ndarray, face_axis: np.ndarray) -> np.ndarray:
    """``|cos| x s`` of every cross axis with the face normal ``face_axis`` (n, 9), NaN where
    the two are perpendicular by construction (rule 1 never applies)."""
    n = len(r)
    out = np.full((n, 9), np.nan)
    for c, (i, j) in enumerate(CROSS_IJ):
        for f in range(6):
            rows = face_axis == f
            if f < 3 and f != i:
                out[rows, c] = np.abs(r[rows, 3 - i - f, j])
            elif f >= 3 and f - 3 != j:
                out[rows, c] = np.abs(r[rows, i, 3 - j - (f - 3)])
    return out


def first_two(values: np.ndarray):
    """Per row: index of the first minimum, the minimum and the next smallest (n,)."""
    order = np.argsort(values, axis=1, kind="stable")
    picked = np.take_along_axis(values, order[:, :2], axis=1)
    return order[:, 0], picked[:, 0], picked[:, 1]


def edge_parameters(pose: Local, normal: np.ndarray, axis: np.ndarray):
    """Rule 3 for cross axes ``axis`` (n,) with oriented normals (n, 3), A's frame: the free
    closest-point parameters ``s``, ``t`` (metres from each edge's middle), each edge's
    half-length, and the components that name the edges (normal in A's, then B's frame)."""
    n = len(axis)
    i, j = (axis - 6) // 3, (axis - 6) % 3
    rows = np.arange(n)
    centre_a = np.where(np.arange(3) == i[:, None], 0.0,
                        np.where(normal >= 0.0, pose.ha, -pose.ha))
    in_b = np.einsum("nkj,nk->nj", pose.r, normal)
    local_b = np.where(np.arange(3) == j[:, None], 0.0, np.where(in_b >= 0.0, -pose.hb, pose.hb))
    centre_b = pose.t + np.einsum("nij,nj->ni", pose.r, local_b)
    dir_b = pose.r[rows, :, j]
    offset = centre_b - centre_a
    cos = dir_b[rows, i]
    sine2 = 1.0 - cos * cos
    proj_a, proj_b = offset[rows, i], np.einsum("ni,ni->n", offset, dir_b)
    safe = np.where(sine2 > 0.0, sine2, 1.0)
    s_free, t_free = (proj_a - cos * proj_b) / safe, (cos * proj_a - proj_b) / safe
    sides = np.concatenate([np.where(np.arange(3) == i[:, None], np.inf, np.abs(normal)),
                            np.where(np.arange(3) == j[:, None], np.inf, np.abs(in_b))], 1)
    return s_free, t_free, pose.ha[rows, i], pose.hb[rows, j], sides.min(axis=1)
