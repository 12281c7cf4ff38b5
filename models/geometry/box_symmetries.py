"""Box symmetries: the signed permutations that map a box onto itself and their action on
feature ids.

Symmetries. :data:`SIGNED_PERMUTATIONS` holds the 48 signed permutation matrices S (rotations,
det +1, and reflections, det -1), ``(S x)_r = s_r * x[p[r]]``, at index ``8 * k + 4 * (s_0 < 0)
+ 2 * (s_1 < 0) + (s_2 < 0)`` with k the rank of p in ``itertools.permutations(range(3))``:
index 0 is the identity, 0-7 the pure sign flips. S maps the box onto itself when it permutes
only axes of equal size (:func:`box_symmetries`); then the feature with sign vector sigma goes
to the one with sign vector ``S sigma`` (:func:`feature_permutation`).

Acting on a relative pose. Let B sit in A's frame at position t with rotation R (a point
``x_B`` of B is at ``R x_B + t`` in A's frame). Relabel A's frame by a symmetry S of A and
B's frame by a symmetry T of B (``x_A' = S x_A``, ``x_B' = T x_B``); both boxes are unchanged
as sets, so the same physical contact is described by the pose::

    t -> S t,    R -> S R T^T,

with A's features mapped by ``feature_permutation(S)``, B's by ``feature_permutation(T)``,
and the contact normal and point, both in A's frame, by ``n -> S n``, ``p -> S p``; depth and
contact type are unchanged (world-frame results are first brought into A's frame). Since
``det(S R T^T) = det(S) det(T)``, a reflection S keeps R a proper rotation only when paired
with a reflection T: the pair must have ``det(S) == det(T)`` (:func:`proper_pairs`).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.geometry.box_feature_ids import (
    FEATURE_PERMUTATIONS,
    FEATURE_SIGNS,
    N_FEATURES,
    NO_FEATURE,
    SIGNED_PERMUTATION_DETS,
    SIGNED_PERMUTATIONS,
    check_ids,
    id_of_signs,
)

#: Relative tolerance (dimensionless) under which two box sizes count as equal, so that the
#: axis permutation swapping them is a symmetry. 1e-6 absorbs round-off of sizes that went
#: through float32 (2**-24 ~ 6e-8) or a text round-trip, yet on a 12 m container it is 12 um,
#: far below manufacturing tolerances and the penetration depths that matter, so treating such
#: boxes as equal moves no contact measurably.
SIZE_REL_TOL = 1e-6


def box_symmetry_indices(size, rel_tol=SIZE_REL_TOL):
    """Indices into :data:`SIGNED_PERMUTATIONS` of the symmetries of one box.

    Sizes are grouped by chaining: after sorting, neighbours within ``rel_tol`` (relative to
    the larger) are equal, so the result is always a group even when ``a ~ b ~ c`` but not
    ``a ~ c``. All 8 sign flips always qualify.

    Parameters
    ----------
    size : array_like, shape (3,)
        Full edge lengths in metres.
    rel_tol : float
        Relative size tolerance (dimensionless), default :data:`SIZE_REL_TOL`.

    Returns
    -------
    ndarray of int64, shape (m,)
        Ascending; m is 8, 16 or 48.
    """
    size = np.asarray(size, dtype=np.float64)
    if size.shape != (3,) or not np.all(np.isfinite(size) & (size > 0)):
        raise ValueError("size must be 3 finite positive lengths")
    order = np.argsort(size)
    s = size[order]
    new_group = np.diff(s) > rel_tol * s[1:]  # sorted, positive: s[1:] is the larger
    label = np.empty(3, dtype=np.int64)
    label[order] = np.concatenate([[0], np.cumsum(new_group)])
    perm_label = np.abs(SIGNED_PERMUTATIONS) @ label  # label[p[r]] for row r
    return np.flatnonzero(np.all(perm_label == label, axis=-1))


def box_symmetries(size, rel_tol=SIZE_REL_TOL):
    """Signed permutations that map the box of ``size`` onto itself, int, shape (m, 3, 3).

    See :func:`box_symmetry_indices`: 48 for a cube, 16 with two equal sizes, else 8.
    """
    return SIGNED_PERMUTATIONS[box_symmetry_indices(size, rel_tol)]


def feature_permutation(S):
    """Where each feature goes under ``x -> S x``.

    Parameters
    ----------
    S : array_like, matrices (..., 3, 3) or int indices (...) into SIGNED_PERMUTATIONS
        Signed permutations; meaningful for a box whose sizes S preserves.

    Returns
    -------
    ndarray of int64, shape (..., 26)
        ``perm[f]`` is the id of the image of feature ``f`` (kind preserved). Composition:
        ``feature_permutation(S1 @ S2) == feature_permutation(S1)[feature_permutation(S2)]``.
    """
    s = np.asarray(S)
    if s.shape[-2:] != (3, 3):
        if not np.issubdtype(s.dtype, np.integer) or np.any((s < 0) | (s >= 48)):
            raise ValueError("S must be matrices (..., 3, 3) or integer indices in 0..47")
        return FEATURE_PERMUTATIONS[s]
    m = np.rint(s).astype(np.int64)
    if (not np.allclose(s, m) or np.any(np.abs(m) > 1)
            or np.any(np.abs(m).sum(-1) != 1) or np.any(np.abs(m).sum(-2) != 1)):
        raise ValueError("S must be signed permutation matrices")
    return id_of_signs(FEATURE_SIGNS @ np.swapaxes(m, -1, -2))  # row f: id of S sigma_f


def map_features(S, ids):
    """Apply symmetries to feature ids, keeping -1 as -1.

    Parameters
    ----------
    S : array_like, int indices (b...) into SIGNED_PERMUTATIONS or matrices (b..., 3, 3)
        The symmetries.
    ids : array_like of int, shape broadcastable with (b...)
        Feature ids in -1..25.

    Returns
    -------
    ndarray of int64, broadcast shape of (b...) and ``ids.shape``
    """
    ids = check_ids(ids)
    table = feature_permutation(S)
    table = np.concatenate([table, np.full(table.shape[:-1] + (1,), NO_FEATURE)], axis=-1)
    shape = np.broadcast_shapes(table.shape[:-1], ids.shape)
    table = np.broadcast_to(table, shape + (N_FEATURES + 1,))
    return np.take_along_axis(table, np.broadcast_to(ids, shape)[..., None], axis=-1)[..., 0]


def canonical_sign_flip(v):
    """Diagonal ``d`` (..., 3), int +-1, of the sign matrix that maps ``v`` into ``d * v >= 0``.

    ``v`` (..., 3): vectors in any unit (e.g. metres). Ties (0 and -0.0) give +1;
    ``sign_flip_index(d)`` is the index of ``diag(d)`` in :data:`SIGNED_PERMUTATIONS`.
    """
    return np.where(np.asarray(v) < 0, -1, 1).astype(np.int64)


def sign_flip_index(d):
    """Index (...,) into :data:`SIGNED_PERMUTATIONS` of the sign flips ``diag(d)``, d (..., 3)."""
    neg = (np.asarray(d) < 0).astype(np.int64)
    return 4 * neg[..., 0] + 2 * neg[..., 1] + neg[..., 2]


def proper_pairs(size_a, size_b, rel_tol=SIZE_REL_TOL):
    """Pairs of symmetries (S of A, T of B) with ``det(S) == det(T)``, keeping R proper.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,)
        Full sizes of boxes A and B in metres.
    rel_tol : float
        Relative size tolerance, see :func:`box_symmetry_indices`.

    Returns
    -------
    ndarray of int64, shape (k, 2)
        Rows ``(i, j)``: ``box_symmetries(size_a)[i]`` with ``box_symmetries(size_b)[j]``,
        ordered by i then j.
    """
    det_a = SIGNED_PERMUTATION_DETS[box_symmetry_indices(size_a, rel_tol)]
    det_b = SIGNED_PERMUTATION_DETS[box_symmetry_indices(size_b, rel_tol)]
    return np.argwhere(det_a[:, None] == det_b[None, :]).astype(np.int64)
