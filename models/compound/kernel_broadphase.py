"""Stage 1 of the compiled compound pipeline: the broadphase of one pose (scalar row functions).

Each part's bounds (a box part itself, a convex part's axis-aligned bounding box in its body's
frame) are an oriented box in the world with its body's rotation. Two boxes are tested on the
six face axes of the two (the box solver's face tests without its edge axes, so nothing that
touches is culled, :data:`ABS_ROTATION_EPS` of slack on top). Two levels: the bounds of the
groups (:mod:`impactnet.models.compound.broadphase`), then the member part pairs of each group
pair that passes, in the order (group of A, group of B, part of A, part of B); bodies whose
parts are all their own groups test their parts at level 1 alone.

Every sum is the NumPy broadphase's (:mod:`impactnet.models.compound.kernel_frame`: its
products went through ``np.matmul``), so the candidates are the same part pairs:

* level 1: ``R = R_A^T R_B`` and ``t_B = R_A^T (p_B - p_A)`` fused; B's box centres
  ``t_B + R c`` and reaches ``|R| h_B`` fused (a body of one box: ``gemv_t``'s order); A's
  reaches ``h_A |R|`` and the offsets in B's frame ``t R`` fused;
* level 2: ``R c`` and ``|R| h_B`` in ``gemv_t``'s order (a stack of matrices times vectors),
  ``t R`` and ``h_A |R|`` fused.
"""
from __future__ import annotations

from impactnet.models.compiled import jit
from impactnet.models.compound.kernel_frame import fused, fused_gemv, fused_product

#: Added to |R| (dimensionless): a pair touching within round-off is never culled (the
#: narrowphase decides it). The NumPy broadphase's constant.
ABS_ROTATION_EPS = 1e-12


@jit
def relative(rot_a, rot_b, offset):
    """``(R, |R| + eps, t_B)`` of a pose: B's rotation and origin in A's frame (9-, 9-,
    3-tuples), rounded as the NumPy broadphase rounded them."""
    rel = fused_product(rot_a, rot_b)
    absolute = (abs(rel[0]) + ABS_ROTATION_EPS, abs(rel[1]) + ABS_ROTATION_EPS,
                abs(rel[2]) + ABS_ROTATION_EPS, abs(rel[3]) + ABS_ROTATION_EPS,
                abs(rel[4]) + ABS_ROTATION_EPS, abs(rel[5]) + ABS_ROTATION_EPS,
                abs(rel[6]) + ABS_ROTATION_EPS, abs(rel[7]) + ABS_ROTATION_EPS,
                abs(rel[8]) + ABS_ROTATION_EPS)
    a = rot_a
    t = (fused(a[0], a[3], a[6], offset[0], offset[1], offset[2]),
         fused(a[1], a[4], a[7], offset[0], offset[1], offset[2]),
         fused(a[2], a[5], a[8], offset[0], offset[1], offset[2]))
    return rel, absolute, t


@jit
def _times(m, v, one):
    """``M v`` (3-tuple) of a row-major 9-tuple: fused in ``gemm``'s order, or in ``gemv_t``'s
    where ``one`` (NumPy's product of a stack of matrices and one vector)."""
    if one:
        return (fused_gemv(m[0], m[1], m[2], v[0], v[1], v[2]),
                fused_gemv(m[3], m[4], m[5], v[0], v[1], v[2]),
                fused_gemv(m[6], m[7], m[8], v[0], v[1], v[2]))
    return (fused(m[0], m[1], m[2], v[0], v[1], v[2]), fused(m[3], m[4], m[5], v[0], v[1], v[2]),
            fused(m[6], m[7], m[8], v[0], v[1], v[2]))


@jit
def _before(v, m):
    """``v M`` (3-tuple) of a row-major 9-tuple, fused."""
    return (fused(v[0], v[1], v[2], m[0], m[3], m[6]), fused(v[0], v[1], v[2], m[1], m[4], m[7]),
            fused(v[0], v[1], v[2], m[2], m[5], m[8]))


@jit
def _within(t, reach_a, reach_b, rel):
    """Whether offset ``t`` (A's frame) lies within ``reach_a`` on A's axes and ``t R`` within
    ``reach_b`` on B's."""
    if not (abs(t[0]) <= reach_a[0] and abs(t[1]) <= reach_a[1] and abs(t[2]) <= reach_a[2]):
        return False
    u = _before(t, rel)
    return abs(u[0]) <= reach_b[0] and abs(u[1]) <= reach_b[1] and abs(u[2]) <= reach_b[2]


@jit
def _half(size, k):
    """Half the extents of box k of (m, 3) sizes (3-tuple)."""
    return 0.5 * size[k, 0], 0.5 * size[k, 1], 0.5 * size[k, 2]


@jit
def _row(array, k):
    """Row k of an (m, 3) array (3-tuple)."""
    return array[k, 0], array[k, 1], array[k, 2]


@jit
def _level_one(boxes_a, boxes_b, g0, g1, h0, h1, pose, scratch):
    """Level 1's per-pose terms into ``scratch`` (B's box centres in A's frame, B's reaches on
    A's axes, A's reaches on B's axes), boxes ``g0:g1`` of A and ``h0:h1`` of B."""
    size_a = boxes_a[1]
    centre_b, size_b = boxes_b
    rel, absolute, t = pose
    placed, reach_b, reach_a = scratch
    one = h1 - h0 == 1
    for k in range(h1 - h0):
        c = _times(rel, _row(centre_b, h0 + k), one)
        placed[k, 0], placed[k, 1], placed[k, 2] = t[0] + c[0], t[1] + c[1], t[2] + c[2]
        r = _times(absolute, _half(size_b, h0 + k), one)
        reach_b[k, 0], reach_b[k, 1], reach_b[k, 2] = r[0], r[1], r[2]
    for k in range(g1 - g0):
        r = _before(_half(size_a, g0 + k), absolute)
        reach_a[k, 0], reach_a[k, 1], reach_a[k, 2] = r[0], r[1], r[2]


@jit
def _boxes_meet(boxes_a, boxes_b, ga, gb, k_a, k_b, rel, scratch):
    """Level 1's test of A's box ``ga`` (its row ``k_a`` of the scratch) and B's ``gb``."""
    (centre_a, size_a), (_, size_b) = boxes_a, boxes_b
    placed, reach_b, reach_a = scratch
    t = (placed[k_b, 0] - centre_a[ga, 0], placed[k_b, 1] - centre_a[ga, 1],
         placed[k_b, 2] - centre_a[ga, 2])
    ha, hb = _half(size_a, ga), _half(size_b, gb)
    return _within(t, (ha[0] + reach_b[k_b, 0], ha[1] + reach_b[k_b, 1], ha[2] + reach_b[k_b, 2]),
                   (hb[0] + reach_a[k_a, 0], hb[1] + reach_a[k_a, 1], hb[2] + reach_a[k_a, 2]),
                   rel)


@jit
def _parts_meet(parts_a, parts_b, i, j, pose):
    """Level 2's test of A's part i and B's part j (NumPy's per-pair products)."""
    (centre_a, size_a), (centre_b, size_b) = parts_a, parts_b
    rel, absolute, t_b = pose
    c = _times(rel, _row(centre_b, j), True)
    t = ((t_b[0] + c[0]) - centre_a[i, 0], (t_b[1] + c[1]) - centre_a[i, 1],
         (t_b[2] + c[2]) - centre_a[i, 2])
    ha, hb = _half(size_a, i), _half(size_b, j)
    r = _times(absolute, hb, True)
    s = _before(ha, absolute)
    return _within(t, (ha[0] + r[0], ha[1] + r[1], ha[2] + r[2]),
                   (hb[0] + s[0], hb[1] + s[1], hb[2] + s[2]), rel)


@jit
def pose_candidates(body_a, a, body_b, b, pose, scratch, cand_a, cand_b, at, write):
    """The candidate part pairs of one pose: their count, and where ``write``, each pair's
    parts (the bodies' own indices) at ``cand_a[at + c]``, ``cand_b[at + c]``, in the NumPy
    broadphase's order (module docstring).

    Parameters
    ----------
    body_a, body_b : BodyViews
        The sets' body sections (:mod:`impactnet.models.compound.kernel_tables`).
    a, b : int
        The pose's body in each set.
    pose : tuple
        :func:`relative` of the pose.
    scratch : tuple of ndarray
        Three (>= boxes of a body, 3) float64 arrays.
    """
    p0, g0, g1 = body_a.body_part[a], body_a.body_group[a], body_a.body_group[a + 1]
    q0, h0, h1 = body_b.body_part[b], body_b.body_group[b], body_b.body_group[b + 1]
    parts_a, parts_b = (body_a.part_centre, body_a.part_size), (body_b.part_centre,
                                                                 body_b.part_size)
    single = body_a.body_singleton[a] and body_b.body_singleton[b]
    if single:  # level 1 on the parts themselves
        boxes_a, boxes_b = parts_a, parts_b
        g0, g1, h0, h1 = p0, body_a.body_part[a + 1], q0, body_b.body_part[b + 1]
    else:
        boxes_a = (body_a.group_centre, body_a.group_size)
        boxes_b = (body_b.group_centre, body_b.group_size)
    _level_one(boxes_a, boxes_b, g0, g1, h0, h1, pose, scratch)
    count = 0
    members_a, starts_a = body_a.member, body_a.member_start
    members_b, starts_b = body_b.member, body_b.member_start
    for ga in range(g0, g1):
        for gb in range(h0, h1):
            if not _boxes_meet(boxes_a, boxes_b, ga, gb, ga - g0, gb - h0, pose[0], scratch):
                continue
            if single:
                if write:
                    cand_a[at + count], cand_b[at + count] = ga - p0, gb - q0
                count += 1
                continue
            for s in range(starts_a[ga], starts_a[ga + 1]):
                i = members_a[s]
                for r in range(starts_b[gb], starts_b[gb + 1]):
                    j = members_b[r]
                    if _parts_meet(parts_a, parts_b, i, j, pose):
                        if write:
                            cand_a[at + count], cand_b[at + count] = i - p0, j - q0
                        count += 1
    return count
