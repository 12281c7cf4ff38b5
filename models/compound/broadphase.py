"""The compound oracle's broadphase: which part pairs of N poses may touch, vectorised.

Each part is represented by its bounds in its body's frame (a box part itself, a convex part's
axis-aligned bounding box), so a part's bounds are an oriented box in the world with its
body's rotation. Two bounds are tested on the six face axes of the two boxes (the box solver's
face tests without its edge axes: nothing that touches is culled, a few pairs that do not
touch pass to the exact narrowphase).

Two levels. A part named ``group/name`` belongs to ``group`` (a corner casting's pieces);
any other part is its own group. Level 1 tests the groups' bounds (the union of their parts')
over all ``n x G_a x G_b`` at once, chunked over poses; level 2 tests the member pairs of the
surviving group pairs only, as a flat list of (pose, part_a, part_b) items. A detailed body's
cost then grows with the parts near the contact, not with all of them. Bodies whose parts are
all their own groups skip level 2.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

#: Box pairs (poses x A's boxes x B's boxes) per level-1 chunk: its (chunk, G_a, G_b, 3)
#: arrays stay a few tens of MB whatever the bodies' part counts.
LEVEL_ONE_ITEMS = 1 << 19
#: Member part pairs per level-2 step: its per-pair arrays (~300 bytes each) stay ~40 MB.
LEVEL_TWO_ITEMS = 1 << 17
#: Added to |R| (dimensionless): a pair touching within round-off is never culled (the
#: narrowphase decides it).
ABS_ROTATION_EPS = 1e-12
#: Separator of a part's group and its own name.
GROUP_SEPARATOR = "/"


def groups_of(parts) -> tuple[np.ndarray, list[np.ndarray]]:
    """(group of each part (P,), members of each group), groups in order of first part."""
    keys = [p.name.split(GROUP_SEPARATOR, 1)[0] if GROUP_SEPARATOR in p.name else p.name
            for p in parts]
    order = list(dict.fromkeys(keys))
    group = np.array([order.index(k) for k in keys], np.int64)
    return group, [np.flatnonzero(group == g) for g in range(len(order))]


def _overlap(t, rel, absolute, half_a, half_b):
    """Whether boxes of half extents ``half_a`` (.., 3) at the origin and ``half_b`` (.., 3) at
    ``t`` (.., 3) rotated by ``rel`` (.., 3, 3) overlap on A's and B's face axes."""
    reach_a = half_a + (absolute @ half_b[..., None])[..., 0]
    ok = (np.abs(t) <= reach_a).all(axis=-1)
    u = (t[..., None, :] @ rel)[..., 0, :]  # the offset in B's frame
    reach_b = half_b + (half_a[..., None, :] @ absolute)[..., 0, :]
    return ok & (np.abs(u) <= reach_b).all(axis=-1)


def _level_one(centre_a, size_a, centre_b, size_b, offset, rot_a, rot_b):
    """(pose, box_a, box_b) of the box pairs not separated, pose-major; all pairs at once."""
    found = []
    half_a, half_b = 0.5 * size_a, 0.5 * size_b
    chunk = max(1, LEVEL_ONE_ITEMS // (len(size_a) * len(size_b)))
    for start in range(0, len(offset), chunk):
        stop = min(len(offset), start + chunk)
        ra_t, rb = rot_a[start:stop].transpose(0, 2, 1), rot_b[start:stop]
        rel = ra_t @ rb  # R = R_A^T R_B, (m, 3, 3)
        absolute = np.abs(rel) + ABS_ROTATION_EPS
        t_b = (ra_t @ offset[start:stop, :, None])[:, :, 0]  # B's origin in A's frame
        centres_b = t_b[:, None, :] + (rel @ centre_b.T).transpose(0, 2, 1)  # (m, Pb, 3)
        t = centres_b[:, None, :, :] - centre_a[None, :, None, :]  # (m, Pa, Pb, 3)
        reach_a = half_a[None, :, None, :] + (absolute @ half_b.T).transpose(0, 2, 1)[:, None]
        ok = (np.abs(t) <= reach_a).all(axis=3)
        m, pa, pb = ok.shape
        u = (t.reshape(m, pa * pb, 3) @ rel).reshape(m, pa, pb, 3)  # the offsets, B's frame
        reach_b = half_b[None, None, :, :] + (half_a @ absolute)[:, :, None, :]
        ok &= (np.abs(u) <= reach_b).all(axis=3)
        pose, i, j = np.nonzero(ok)
        found.append((pose + start, i, j))
    return tuple(np.concatenate(parts) for parts in zip(*found))


def _member_pairs(table_a, table_b):
    """:func:`_cached_member_pairs`, outside the cache where a body is transient
    (:class:`~impactnet.models.compound.body_table.TransientParts`)."""
    if table_a.transient or table_b.transient:
        return _cached_member_pairs.__wrapped__(table_a, table_b)
    return _cached_member_pairs(table_a, table_b)


@lru_cache(maxsize=64)
def _cached_member_pairs(table_a, table_b):
    """CSR table of the member part pairs of every group pair: (start (G_a * G_b + 1,),
    part_a, part_b)."""
    members_a, members_b = table_a.members, table_b.members
    count = np.array([len(ma) * len(mb) for ma in members_a for mb in members_b])
    start = np.zeros(len(count) + 1, np.int64)
    np.cumsum(count, out=start[1:])
    pairs = [np.meshgrid(ma, mb, indexing="ij") for ma in members_a for mb in members_b]
    return (start, np.concatenate([i.ravel() for i, _ in pairs]),
            np.concatenate([j.ravel() for _, j in pairs]))


def broadphase(table_a, table_b, offset, rot_a, rot_b):
    """(pose, part_a, part_b) of the part pairs that may touch, pose-major (module docstring).

    Parameters
    ----------
    table_a, table_b : impactnet.models.compound.body_table.BodyTable
        The bodies' parts: bounds (centres and sizes, body frame, metres) and groups.
    offset : ndarray, shape (n, 3)
        ``p_B - p_A`` (metres, world).
    rot_a, rot_b : ndarray, shape (n, 3, 3)
        The bodies' rotations.
    """
    bounds_a, bounds_b = (table_a.centre, table_a.size), (table_b.centre, table_b.size)
    members_a, members_b = table_a.members, table_b.members
    if len(members_a) == len(table_a.parts) and len(members_b) == len(table_b.parts):
        return _level_one(*bounds_a, *bounds_b, offset, rot_a, rot_b)
    pose, ga, gb = _level_one(*table_a.group_bounds, *table_b.group_bounds, offset, rot_a,
                              rot_b)
    start, pair_a, pair_b = _member_pairs(table_a, table_b)
    key = ga * len(members_b) + gb
    count = start[key + 1] - start[key]
    # per pose once: R = R_A^T R_B and B's origin in A's frame
    ra_t = rot_a.transpose(0, 2, 1)
    rel_pose = ra_t @ rot_b
    t_pose = (ra_t @ offset[:, :, None])[:, :, 0]
    found = []
    for lo, hi in _item_slices(count, LEVEL_TWO_ITEMS):
        found.append(_level_two(pose[lo:hi], start[key[lo:hi]], count[lo:hi],
                                (pair_a, pair_b), rel_pose, t_pose, bounds_a, bounds_b))
    if not found:
        return pose[:0], pose[:0], pose[:0]
    return tuple(np.concatenate(parts) for parts in zip(*found))


def _item_slices(count: np.ndarray, budget: int) -> list[tuple[int, int]]:
    """Consecutive slices of the level-1 survivors, each with at most ``budget`` member pairs
    (a survivor with more is a slice of its own)."""
    ends = np.cumsum(count)
    slices, lo = [], 0
    while lo < len(count):
        base = ends[lo - 1] if lo else 0
        hi = max(int(np.searchsorted(ends, base + budget, side="right")), lo + 1)
        slices.append((lo, hi))
        lo = hi
    return slices


def _level_two(pose, first_pair, count, pairs, rel_pose, t_pose, bounds_a, bounds_b):
    """(pose, part_a, part_b) of the member pairs of some level-1 survivors (pose (k,), their
    first member pair and count) whose bounds are not separated."""
    pair_a, pair_b = pairs
    item_pose = np.repeat(pose, count)
    at = np.repeat(first_pair - np.cumsum(count) + count, count) + np.arange(len(item_pose))
    i, j = pair_a[at], pair_b[at]
    (centre_a, size_a), (centre_b, size_b) = bounds_a, bounds_b
    rel = rel_pose[item_pose]
    t = t_pose[item_pose] + (rel @ centre_b[j][:, :, None])[:, :, 0] - centre_a[i]
    ok = _overlap(t, rel, np.abs(rel) + ABS_ROTATION_EPS, 0.5 * size_a[i], 0.5 * size_b[j])
    return item_pose[ok], i[ok], j[ok]
