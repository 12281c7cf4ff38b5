"""A packed set of bodies (:mod:`impactnet.models.compound.flat_tables`) turned back into named
views inside a kernel: :func:`body_views` (the parts, groups and partners) and :func:`hull_views`
(the hull table, the same types as :attr:`~impactnet.models.compound.hull_stack.HullTable.arrays`:
read-only C-contiguous arrays, so the convex solver's kernels serve both). A kernel unpacks once per
call (or per block of rows of a parallel launch): each view costs a reference count, which the
kernel threads would contend for if taken per row.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models.compiled import jit
from impactnet.models.compound.flat_tables import SECTION
from impactnet.models.compound.hull_stack import HullArrays


class BodyViews(NamedTuple):
    """The body sections of a set (:mod:`~impactnet.models.compound.flat_tables`), numbered
    across the set."""

    body_part: np.ndarray  # (B + 1,) int64 CSR starts of each body's parts
    body_group: np.ndarray  # (B + 1,) int64 CSR starts of each body's groups
    body_singleton: np.ndarray  # (B,) bool every part its own group
    group_centre: np.ndarray  # (G, 3) centres of the groups' bounds (m, body frame)
    group_size: np.ndarray  # (G, 3) extents of the groups' bounds (m)
    member_start: np.ndarray  # (G + 1,) int64 CSR starts of each group's members
    member: np.ndarray  # (P,) int64 parts, group by group, ascending
    part_centre: np.ndarray  # (P, 3) centres of the parts' bounds (m, body frame)
    part_size: np.ndarray  # (P, 3) extents of the parts' bounds (m)
    margin: np.ndarray  # (P,) the covered-surface filter's margin of each part (m)
    is_box: np.ndarray  # (P,) bool a box part (its bounds are the part)
    partner_start: np.ndarray  # (P + 1,) int64 CSR starts of each part's partners
    partner: np.ndarray  # (K,) int64 the parts whose bounds overlap each part's
    widest: np.ndarray  # (7,) int64 largest parts, groups per body; V, F, E, N, L per hull


@jit
def _flat(buffer, ints, k):
    """Section k of a buffer, flat (a view)."""
    return buffer[ints[2 * k]:ints[2 * k + 1]]


@jit
def _rows(buffer, ints, k, width):
    """Section k of a buffer as (n, width) rows (a view)."""
    flat = buffer[ints[2 * k]:ints[2 * k + 1]]
    return flat.reshape((flat.shape[0] // width, width))


@jit
def _frames(buffer, ints, k):
    """Section k of a buffer as (n, 3, 3) matrices (a view)."""
    flat = buffer[ints[2 * k]:ints[2 * k + 1]]
    return flat.reshape((flat.shape[0] // 9, 3, 3))


#: Section indices (:data:`~impactnet.models.compound.flat_tables.SECTIONS`): the body
#: sections by name, the hull table's from ``H`` in the order of its fields.
(BODY_PART, BODY_GROUP, BODY_SINGLETON, GROUP_CENTRE, GROUP_SIZE, MEMBER_START, MEMBER,
 PART_CENTRE, PART_SIZE, MARGIN, IS_BOX, PARTNER_START, PARTNER) = range(13)
H = SECTION["vertex_start"]
WIDEST = SECTION["widest"]


@jit
def body_views(reals, ints, flags):
    """The :class:`BodyViews` of a packed set's three buffers."""
    return BodyViews(
        _flat(ints, ints, BODY_PART), _flat(ints, ints, BODY_GROUP),
        _flat(flags, ints, BODY_SINGLETON), _rows(reals, ints, GROUP_CENTRE, 3),
        _rows(reals, ints, GROUP_SIZE, 3), _flat(ints, ints, MEMBER_START),
        _flat(ints, ints, MEMBER), _rows(reals, ints, PART_CENTRE, 3),
        _rows(reals, ints, PART_SIZE, 3), _flat(reals, ints, MARGIN),
        _flat(flags, ints, IS_BOX), _flat(ints, ints, PARTNER_START),
        _flat(ints, ints, PARTNER), _flat(ints, ints, WIDEST))


@jit
def hull_views(reals, ints, flags):
    """The :class:`~impactnet.models.compound.hull_stack.HullArrays` of a packed set's three
    buffers (one hull per part, in part order); argument i is field i, section ``H + i``."""
    return HullArrays(
        _flat(ints, ints, H), _flat(ints, ints, H + 1), _flat(ints, ints, H + 2),
        _flat(ints, ints, H + 3), _rows(reals, ints, H + 4, 3), _flat(reals, ints, H + 5),
        _flat(reals, ints, H + 6), _flat(reals, ints, H + 7), _flat(reals, ints, H + 8),
        _flat(flags, ints, H + 9), _flat(flags, ints, H + 10), _flat(reals, ints, H + 11),
        _flat(reals, ints, H + 12), _rows(reals, ints, H + 13, 3), _flat(ints, ints, H + 14),
        _flat(ints, ints, H + 15), _flat(ints, ints, H + 16), _flat(ints, ints, H + 17),
        _flat(ints, ints, H + 18), _rows(reals, ints, H + 19, 3), _flat(reals, ints, H + 20),
        _frames(reals, ints, H + 21), _flat(ints, ints, H + 22), _flat(ints, ints, H + 23),
        _rows(reals, ints, H + 24, 4), _flat(ints, ints, H + 25), _flat(ints, ints, H + 26),
        _rows(ints, ints, H + 27, 2), _rows(ints, ints, H + 28, 2),
        _rows(reals, ints, H + 29, 3), _rows(reals, ints, H + 30, 4),
        _rows(reals, ints, H + 31, 3), _rows(reals, ints, H + 32, 3),
        _flat(reals, ints, H + 33), _flat(reals, ints, H + 34), _flat(reals, ints, H + 35),
        _flat(ints, ints, H + 36), _flat(ints, ints, H + 37), _flat(ints, ints, H + 38),
        _flat(ints, ints, H + 39), _rows(reals, ints, H + 40, 3), _flat(reals, ints, H + 41),
        _flat(reals, ints, H + 42), _flat(ints, ints, H + 43))
