"""Part groups of a compound pair and the input features of their classifiers (issue #21).

The touching part pairs of a compound pair factorise by corner: a bottom casting or a twistlock
head at corner ``c`` of body B meets the top casting at corner ``c`` of body A, whatever the
detail of either. A *group* is one such corner (A's parts named ``casting_top_<c>/...``, B's
``casting_bottom_<c>/...`` or ``head_<c>``); a part pair belongs to the first group that holds
either part, and every other part pair (a roof, a spreader's frame, a cell guide's legs) to the
last group, ``body``. Each group's classifier sees the pose of B's group relative to A's group
(:func:`group_features`): the local offset is what decides the contact set, and it does not
grow with the parts' detail.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.parts import bounds

#: The corners of the crane bodies' generated part names.
CORNERS = ("fl", "fr", "al", "ar")
#: Name prefixes of A's corner group (A rests; its top castings) and of B's (the moving body's
#: bottom castings or twistlock heads), before ``_<corner>``.
GROUP_PREFIX_A = ("casting_top",)
GROUP_PREFIX_B = ("casting_bottom", "head")
#: The group of the part pairs of no corner; its features are the pose of B's body.
BODY = "body"
#: Input features per group: B's group centre in A's group frame (3, metres) and the first two
#: columns of B's rotation in A's frame (6).
N_GROUP_FEATURES = 9
#: The mirror that maps each corner onto corner ``fl`` (diagonal of M: ``fr`` across y, ``al``
#: across x, ``ar`` both), for bodies symmetric under both mirrors (:func:`mirror_map`).
CORNER_MIRRORS = {"fl": (1.0, 1.0, 1.0), "fr": (1.0, -1.0, 1.0), "al": (-1.0, 1.0, 1.0),
                  "ar": (-1.0, -1.0, 1.0)}
#: Two parts are mirror images when their bounds agree to this (m): exact up to round-off.
MIRROR_TOL_M = 1e-9


@dataclass(frozen=True)
class PartGroup:
    """One group of a pair: its parts on each body and the centres its features use."""

    name: str  # a corner ("fl", ...) or BODY
    parts_a: tuple[int, ...]  # A's parts in the group (empty for BODY: all the rest)
    parts_b: tuple[int, ...]  # B's parts in the group
    centre_a: tuple[float, float, float]  # A's group centre, A's frame (m)
    centre_b: tuple[float, float, float]  # B's group centre, B's frame (m)


def _owner(name: str) -> str:
    return name.split("/")[0]


def bounds_centre(parts, members) -> tuple[float, float, float]:
    """The centre (m, body frame) of the bounds of ``parts[k]`` for k in ``members``."""
    lows, highs = zip(*(bounds(parts[k]) for k in members))
    return tuple(float(v) for v in 0.5 * (np.min(lows, axis=0) + np.max(highs, axis=0)))


def part_groups(parts_a, parts_b) -> tuple[PartGroup, ...]:
    """The groups of a pair: each corner that both bodies have, then BODY."""
    groups = []
    for corner in CORNERS:
        own_a = tuple(k for k, p in enumerate(parts_a)
                      if _owner(p.name) in {f"{g}_{corner}" for g in GROUP_PREFIX_A})
        own_b = tuple(k for k, p in enumerate(parts_b)
                      if _owner(p.name) in {f"{g}_{corner}" for g in GROUP_PREFIX_B})
        if own_a and own_b:
            groups.append(PartGroup(corner, own_a, own_b, bounds_centre(parts_a, own_a),
                                    bounds_centre(parts_b, own_b)))
    groups.append(PartGroup(BODY, (), (), bounds_centre(parts_a, range(len(parts_a))),
                            bounds_centre(parts_b, range(len(parts_b)))))
    return tuple(groups)


def group_of_pairs(groups: tuple[PartGroup, ...], part_a, part_b) -> np.ndarray:
    """(k,) int: the group index of each part pair (the first corner holding either part,
    else the BODY group, the last)."""
    part_a, part_b = np.asarray(part_a), np.asarray(part_b)
    out = np.full(len(part_a), len(groups) - 1, np.int64)
    for g in range(len(groups) - 2, -1, -1):  # the first group wins: assign in reverse
        mine = np.isin(part_a, groups[g].parts_a) | np.isin(part_b, groups[g].parts_b)
        out[mine] = g
    return out


def group_features(group: PartGroup, position, rotation) -> np.ndarray:
    """(n, 9) float64: B's group centre in A's group frame and B's rotation's first two columns.

    Parameters
    ----------
    position : ndarray, shape (n, 3)
        B's origin in A's frame (m).
    rotation : ndarray, shape (n, 3, 3)
        B's orientation in A's frame.
    """
    at = position + rotation @ np.asarray(group.centre_b) - np.asarray(group.centre_a)
    return np.concatenate([at, rotation[:, :, 0], rotation[:, :, 1]], axis=1)


def mirror_features(x: np.ndarray, mirror) -> np.ndarray:
    """Group features (n, 9) seen through ``mirror`` (3,) (+-1 each): the offset ``M p`` and
    the rotation ``M R M`` (a proper rotation), so that a corner's rows look like corner fl's."""
    m = np.asarray(mirror, np.float64)
    return np.concatenate([x[:, :3] * m, x[:, 3:6] * m * m[0], x[:, 6:9] * m * m[1]], axis=1)


def mirror_map(parts, mirror) -> np.ndarray | None:
    """(p,) int: the index of each part's mirror image under ``mirror`` (the part whose
    bounds are the mirrored bounds), or None where a part has none: the body is not
    symmetric under that mirror. Mirrors are involutions, so the map is its own inverse."""
    lows, highs = (np.array(v) for v in zip(*(bounds(p) for p in parts)))
    centre, extent = 0.5 * (lows + highs), highs - lows
    mirrored = centre * np.asarray(mirror, np.float64)
    out = np.empty(len(parts), np.int64)
    for k in range(len(parts)):
        hit = np.flatnonzero((np.abs(centre - mirrored[k]) < MIRROR_TOL_M).all(axis=1)
                             & (np.abs(extent - extent[k]) < MIRROR_TOL_M).all(axis=1))
        if len(hit) != 1:
            return None
        out[k] = hit[0]
    return out


def relative_pose(position_a, rotation_a, position_b, rotation_b):
    """(position (n, 3), rotation (n, 3, 3)) of B in A's frame, from world poses."""
    rot_a_t = np.swapaxes(rotation_a, -1, -2)
    return (np.einsum("nij,nj->ni", rot_a_t, position_b - position_a),
            rot_a_t @ rotation_b)
