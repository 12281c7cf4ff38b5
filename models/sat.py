"""Separating-axis test for N box pairs, in A's local frame.

Stage 1 of the exact solver (see :mod:`models.exact`). Box A is centred at the origin with
identity orientation; box B has centre ``t`` and rotation ``R`` (B's axes as the columns of R).

The 15 candidate axes are A's face normals (axis ids 0-2), B's face normals (3-5) and the
cross products of A's edge direction i with B's edge direction j (``6 + 3 i + j``). Along a
unit axis u the two boxes overlap by ``r_A(u) + r_B(u) - |t . u|``; the boxes intersect iff
every axis overlaps, and the axis of least overlap gives the contact normal and depth.

Degenerate cross axes (edges within :data:`EDGE_SKEW_TOL_REL` of parallel) are skipped: for
parallel edges the face axes already complete the test, and the overlap along any direction
is never below the true penetration depth, so an imprecise near-parallel axis can only
overestimate and lose; skipping it costs at most the skew times the box size.

Tie rule (deterministic, documented for label stability): the face axis of least overlap
wins over every cross axis unless a cross axis overlaps less by more than
:data:`TIE_TOL_REL` times the pair's scale; among face axes within that tolerance of the
minimum, the lowest axis id wins (A before B; x before y before z). There is no
percentage bias ("fudge factor") towards face axes.
"""
from __future__ import annotations

import numpy as np

#: Relative tolerance (x pair scale, metres) for axis ties: rounding of an overlap is a few
#: ulps of the scale, so differences below this are noise, not geometry.
TIE_TOL_REL = 1e-12
#: Relative tolerance (x pair scale) under which two boxes still count as touching: a pair
#: placed exactly in contact computes an overlap of +-few ulps and must not flicker.
CONTACT_TOL_REL = 1e-12
#: Scale-aware parallel-edge test: a cross axis is skipped when the skew of the two edges
#: (sine of their angle) times the longer edge length is below this fraction of the pair's
#: scale, i.e. when the edges' misalignment over their length is rounding noise.
EDGE_SKEW_TOL_REL = 1e-12
#: Overlap assigned to skipped axes: they neither separate nor win.
SKIPPED_AXIS_OVERLAP = np.inf


def sign_nonnegative(x: np.ndarray) -> np.ndarray:
    """Sign with ties at zero resolved to +1 (deterministic orientation of axes)."""
    return np.where(x >= 0.0, 1.0, -1.0)


def pair_scale(half_a: np.ndarray, half_b: np.ndarray) -> np.ndarray:
    """Length scale of each pair, shape (n,): the sum of both largest half-extents (metres)."""
    return half_a.max(axis=-1) + half_b.max(axis=-1)


def cross_axes(rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 9 edge-edge cross products ``e_i x b_j`` in A's frame.

    Parameters
    ----------
    rotation : ndarray, shape (n, 3, 3)
        B's axes as columns, in A's frame.

    Returns
    -------
    axes : ndarray, shape (n, 9, 3)
        Unnormalised cross products, row ``3 i + j``.
    sine : ndarray, shape (n, 9)
        Their lengths, the sine of the angle between edge i of A and edge j of B.
    """
    r0, r1, r2 = rotation[:, 0, :], rotation[:, 1, :], rotation[:, 2, :]
    zero = np.zeros_like(r0)
    c0 = np.stack([zero, -r2, r1], axis=-1)  # e_x x b_j
    c1 = np.stack([r2, zero, -r0], axis=-1)  # e_y x b_j
    c2 = np.stack([-r1, r0, zero], axis=-1)  # e_z x b_j
    axes = np.stack([c0, c1, c2], axis=1).reshape(-1, 9, 3)
    return axes, np.sqrt(np.einsum("nkc,nkc->nk", axes, axes))


def overlaps(half_a, half_b, rotation, translation):
    """Overlap of the two boxes along each of the 15 axes.

    Parameters
    ----------
    half_a, half_b : ndarray, shape (n, 3)
        Half-extents of A and B (metres).
    rotation : ndarray, shape (n, 3, 3)
        B's axes as columns in A's frame.
    translation : ndarray, shape (n, 3)
        B's centre in A's frame (metres).

    Returns
    -------
    overlap : ndarray, shape (n, 15)
        Overlap (metres) along each axis; negative where the axis separates, +inf where
        a degenerate cross axis was skipped.
    unit_axes : ndarray, shape (n, 15, 3)
        Unit axes in A's frame (zeros for skipped axes), not yet oriented A -> B.
    """
    n = translation.shape[0]
    abs_rot = np.abs(rotation)
    t_in_b = np.einsum("nij,ni->nj", rotation, translation)
    face_a = half_a + np.einsum("nij,nj->ni", abs_rot, half_b) - np.abs(translation)
    face_b = half_b + np.einsum("nij,ni->nj", abs_rot, half_a) - np.abs(t_in_b)

    axes, sine = cross_axes(rotation)
    longer_edge = 2.0 * np.maximum(half_a[:, :, None], half_b[:, None, :]).reshape(n, 9)
    scale = pair_scale(half_a, half_b)
    valid = sine * longer_edge > EDGE_SKEW_TOL_REL * scale[:, None]
    unit = axes / np.where(valid, sine, 1.0)[:, :, None]
    unit[~valid] = 0.0
    radius_a = np.abs(unit) @ half_a[:, :, None]
    radius_b = np.abs(unit @ rotation) @ half_b[:, :, None]
    distance = np.abs(np.einsum("nkc,nc->nk", unit, translation))
    cross = radius_a[..., 0] + radius_b[..., 0] - distance
    cross[~valid] = SKIPPED_AXIS_OVERLAP

    unit_axes = np.empty((n, 15, 3))
    unit_axes[:, 0:3, :] = np.eye(3)
    unit_axes[:, 3:6, :] = np.swapaxes(rotation, 1, 2)
    unit_axes[:, 6:, :] = unit
    return np.concatenate([face_a, face_b, cross], axis=1), unit_axes


def choose_axis(overlap: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pick each pair's contact axis by least overlap and the documented tie rule.

    Parameters
    ----------
    overlap : ndarray, shape (n, 15)
        From :func:`overlaps`.
    scale : ndarray, shape (n,)
        Pair scale (metres) from :func:`pair_scale`.

    Returns
    -------
    colliding : ndarray of bool, shape (n,)
        True where every axis overlaps (within :data:`CONTACT_TOL_REL`).
    axis : ndarray of int64, shape (n,)
        Contact axis for colliding pairs; the axis of largest separation otherwise.
    """
    tie = TIE_TOL_REL * scale
    face = overlap[:, :6]
    face_min = face.min(axis=1)
    face_axis = np.argmax(face <= (face_min + tie)[:, None], axis=1)
    cross_axis = np.argmin(overlap[:, 6:], axis=1)
    cross_min = np.take_along_axis(overlap[:, 6:], cross_axis[:, None], axis=1)[:, 0]
    use_cross = cross_min < face_min - tie
    axis = np.where(use_cross, cross_axis + 6, face_axis)

    colliding = overlap.min(axis=1) >= -CONTACT_TOL_REL * scale
    separating = np.argmin(overlap, axis=1)
    return colliding, np.where(colliding, axis, separating)


def oriented_normal(unit_axes, axis, translation):
    """The chosen unit axis oriented from A towards B, in A's frame, shape (n, 3)."""
    chosen = np.take_along_axis(unit_axes, axis[:, None, None], axis=1)[:, 0, :]
    return chosen * sign_nonnegative(np.einsum("nc,nc->n", chosen, translation))[:, None]
