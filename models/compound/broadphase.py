"""The compound oracle's broadphase: which part pairs of N poses may touch.

Each part is represented by its bounds in its body's frame (a box part itself, a convex part's
axis-aligned bounding box), so a part's bounds are an oriented box in the world with its
body's rotation. Two bounds are tested on the six face axes of the two boxes (the box solver's
face tests without its edge axes: nothing that touches is culled, a few pairs that do not
touch pass to the exact narrowphase).

Two levels. A part named ``group/name`` belongs to ``group`` (a corner casting's pieces);
any other part is its own group (:func:`groups_of`). Level 1 tests the groups' bounds (the
union of their parts'), level 2 the member pairs of the surviving group pairs only: a detailed
body's cost grows with the parts near the contact, not with all of them. Bodies whose parts
are all their own groups skip level 2. The test itself is compiled
(:mod:`impactnet.models.compound.kernel_broadphase`, one pose at a time); :func:`broadphase`
runs it on given rotation matrices (the oracle's own entries take quaternions).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.kernel_broadphase import ABS_ROTATION_EPS

__all__ = ["ABS_ROTATION_EPS", "GROUP_SEPARATOR", "broadphase", "groups_of"]

#: Separator of a part's group and its own name.
GROUP_SEPARATOR = "/"


def groups_of(parts) -> tuple[np.ndarray, list[np.ndarray]]:
    """(group of each part (P,), members of each group), groups in order of first part."""
    keys = [p.name.split(GROUP_SEPARATOR, 1)[0] if GROUP_SEPARATOR in p.name else p.name
            for p in parts]
    order = list(dict.fromkeys(keys))
    group = np.array([order.index(k) for k in keys], np.int64)
    return group, [np.flatnonzero(group == g) for g in range(len(order))]


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
    from impactnet.models.compound.kernel_launch import matrix_candidates

    n = len(offset)
    rows = [np.ascontiguousarray(np.broadcast_to(np.asarray(a, np.float64), shape))
            for a, shape in ((offset, (n, 3)), (rot_a, (n, 3, 3)), (rot_b, (n, 3, 3)))]
    return matrix_candidates(table_a.packed.buffers + table_b.packed.buffers, *rows)
