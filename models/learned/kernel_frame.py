"""The canonical frame of one box pair, compiled: the predictors' stages 2-3 and their inverse,
row functions over Python floats (tuples), as :mod:`impactnet.models.box.kernel_frame`.

Stage 1, B in A's frame (``R = R_A^T R_B``, ``t = R_A^T (p_B - p_A)``, ``R^T t``), is the exact
solver's own (:func:`impactnet.models.box.kernel_views.pair_frame`), so the features here equal
those of the reference functions training uses (:mod:`impactnet.models.learned.canonical`:
``relative_pose``, ``canonicalize``, ``pose_features``) to the last bit where the pair's sizes
are the bundle's (tested): the same float64 operations in the same order.

* :func:`canonical`: the symmetry fold ``S = diag(sign t)``, ``T = diag(sign u)`` with
  ``u = -R^T t`` (ties +1), and the ``pose-v1`` features ``S t / L`` and ``S R T`` (row-major);
* :func:`point_to_world`, :func:`normal_to_world`: a canonical point / L and normal back to
  the world (``p_origin + R_A S L point'``, ``R_A S unit(normal')``), the inverse of
  ``canonical.contact_targets`` as ``canonical.from_canonical`` computes it.
"""
from __future__ import annotations

import math

from impactnet.models.box.kernel_frame import matvec, moved
from impactnet.models.compiled import jit
from impactnet.models.learned.canonical import FALLBACK_NORMAL, N_POSE_FEATURES, NORMAL_NORM_MIN

_FALLBACK = tuple(float(v) for v in FALLBACK_NORMAL)
__all__ = ["N_POSE_FEATURES", "canonical", "normal_to_world", "point_to_world"]


@jit
def _sign(x):
    """-1.0 for x < 0, else +1.0 (ties, 0.0 and -0.0, give +1)."""
    return -1.0 if x < 0.0 else 1.0


@jit
def _flip_index(s):
    """Index of ``diag(s)`` among the sign flips: ``4 (s0 < 0) + 2 (s1 < 0) + (s2 < 0)``."""
    return 4 * int(s[0] < 0.0) + 2 * int(s[1] < 0.0) + int(s[2] < 0.0)


@jit
def canonical(r, t, tb, scale, features):
    """The canonical pose of B in A's frame and its ``pose-v1`` features.

    Parameters
    ----------
    r : 9-tuple
        ``R = R_A^T R_B``, row-major.
    t, tb : 3-tuple
        ``t = R_A^T (p_B - p_A)`` and ``R^T t`` (metres).
    scale : float
        The pair's L (metres): ``max(h_A) + max(h_B)`` of the bundle's sizes.
    features : ndarray of float64, shape (>= 12,)
        Written: ``S t / L`` (3), then ``S R T`` row-major (9).

    Returns
    -------
    s, sign_b : 3-tuple of float
        The diagonals of S and T (+-1.0).
    flip_a, flip_b : int
        Their indices among the sign flips (0-7).
    """
    s = (_sign(t[0]), _sign(t[1]), _sign(t[2]))
    # u = -(S R)^T (S t) = -R^T t exactly (sign flips are exact): T = sign(u), ties +1
    sign_b = (_sign(-tb[0]), _sign(-tb[1]), _sign(-tb[2]))
    for i in range(3):
        features[i] = s[i] * t[i] / scale
        for j in range(3):
            features[3 + 3 * i + j] = s[i] * r[3 * i + j] * sign_b[j]
    return s, sign_b, _flip_index(s), _flip_index(sign_b)


@jit
def point_to_world(origin, rot_a, s, y, at, scale):
    """``origin + R_A S (p L)`` (3-tuple, metres): the canonical point / L ``p = y[at:at + 3]``
    (``contact-v1`` outputs at offset ``at`` of the array ``y``) relative to ``origin`` (A's
    position, or the labeller's unclipped point for an expert's residual), world frame;
    ``rot_a`` row-major, ``s`` the diagonal of S."""
    local = (s[0] * y[at] * scale, s[1] * y[at + 1] * scale, s[2] * y[at + 2] * scale)
    return moved(origin, rot_a, local)


@jit
def normal_to_world(rot_a, s, y, at):
    """``R_A S n`` (3-tuple) with ``n`` the unit vector of the canonical normal
    ``y[at + 3:at + 6]``, or the canonical fallback normal where it is shorter than
    ``NORMAL_NORM_MIN``."""
    n0, n1, n2 = y[at + 3], y[at + 4], y[at + 5]
    norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if norm < NORMAL_NORM_MIN:
        n0, n1, n2 = _FALLBACK
    else:
        n0, n1, n2 = n0 / norm, n1 / norm, n2 / norm
    return matvec(rot_a, (s[0] * n0, s[1] * n1, s[2] * n2))
