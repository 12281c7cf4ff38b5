"""The learned predictors for one pair, in plain Python floats (the N = 1 fast path).

NumPy costs about a microsecond per call whatever the array size, and the batch path
(:mod:`impactnet.models.learned.batch`) makes a few hundred calls, so one pair takes this path: the
same
stages (validation, dispatch, canonical frame, networks, mapping back, ``auto``'s fallback)
with the geometry in Python floats and only the vector-matrix products in NumPy
(:meth:`impactnet.models.learned.mlp.MLP.forward_one`). The canonical frame follows
:mod:`impactnet.models.learned.canonical`
(``R = R_A^T R_B`` from the two matrices, signs with ties +1), so the answer equals the batch
path's row up to float32 rounding (tested).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.decision import answer_one, box_box_one
from impactnet.models.geometry.rotations import quaternion_matrix
from impactnet.models.learned.canonical import FALLBACK_NORMAL, FLIP_FEATURES, NORMAL_NORM_MIN
from impactnet.models.learned.pair_dispatch import MIRROR_AXIS, MIRROR_TYPE, UnsupportedPairError
from impactnet.models.learned.pair_runtime import AUTO_EXACT_TYPES
from impactnet.models.learned.region_label import label_one

_PADDING = [0.0] * (3 * ct.MAX_MANIFOLD_POINTS)
_DEG = 180.0 / math.pi
_FLIP = FLIP_FEATURES.tolist()  # _FLIP[flip][feature], feature -1 -> last entry (-1)
_MIRROR_TYPE, _MIRROR_AXIS = MIRROR_TYPE.tolist(), MIRROR_AXIS.tolist()
_FALLBACK = FALLBACK_NORMAL.tolist()


class Prediction(NamedTuple):
    """A predictor's answer and the committee's spread (0 where no committee answered)."""

    contacts: ct.Contacts
    normal_spread: np.ndarray  # (n,) degrees, largest angle between member normals
    point_spread: np.ndarray  # (n,) metres, largest distance between member points


def _canonical(values, inv_scale):
    """Features (12,) float32, R_A S (9 floats, row-major) and the flip indices of S, T."""
    _, pa, (aw, ax, ay, az), _, pb, (bw, bx, by, bz) = values
    a, b = quaternion_matrix(aw, ax, ay, az), quaternion_matrix(bw, bx, by, bz)
    d0, d1, d2 = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
    t = (a[0] * d0 + a[3] * d1 + a[6] * d2, a[1] * d0 + a[4] * d1 + a[7] * d2,
         a[2] * d0 + a[5] * d1 + a[8] * d2)
    rot = [a[i] * b[j] + a[3 + i] * b[3 + j] + a[6 + i] * b[6 + j]
           for i in (0, 1, 2) for j in (0, 1, 2)]
    s = [-1.0 if v < 0.0 else 1.0 for v in t]
    sign_b = [-1.0 if rot[j] * t[0] + rot[3 + j] * t[1] + rot[6 + j] * t[2] > 0.0 else 1.0
              for j in (0, 1, 2)]  # sign of u = -R^T t, ties +1
    features = [abs(t[0]) * inv_scale, abs(t[1]) * inv_scale, abs(t[2]) * inv_scale]
    features += [rot[3 * i + j] * s[i] * sign_b[j] for i in (0, 1, 2) for j in (0, 1, 2)]
    to_world = [a[3 * i + j] * s[j] for i in (0, 1, 2) for j in (0, 1, 2)]
    flip_a = 4 * (s[0] < 0) + 2 * (s[1] < 0) + (s[2] < 0)
    flip_b = 4 * (sign_b[0] < 0) + 2 * (sign_b[1] < 0) + (sign_b[2] < 0)
    return np.array(features, np.float32), to_world, flip_a, flip_b


def _to_world(pair, y, m, pa):
    """World point, unit normal and depth (clipped at 0) of one contact-v1 output ``y``
    (7 floats); ``m`` = R_A S (9 floats), ``pa`` = A's position."""
    n0, n1, n2 = y[3], y[4], y[5]
    norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    n0, n1, n2 = _FALLBACK if norm < NORMAL_NORM_MIN else (n0 / norm, n1 / norm, n2 / norm)
    normal = [m[0] * n0 + m[1] * n1 + m[2] * n2, m[3] * n0 + m[4] * n1 + m[5] * n2,
              m[6] * n0 + m[7] * n1 + m[8] * n2]
    return _point_to_world(pair, y, m, pa), normal, max(y[6] * pair.edge, 0.0)


def _point_to_world(pair, y, m, pa):
    """World point of the canonical point / L in ``y[:3]`` relative to ``pa`` (A's position,
    or the unclipped point for an expert's residual); ``m`` = R_A S."""
    p0, p1, p2 = y[0] * pair.scale, y[1] * pair.scale, y[2] * pair.scale
    return [pa[0] + m[0] * p0 + m[1] * p1 + m[2] * p2, pa[1] + m[3] * p0 + m[4] * p1
            + m[5] * p2, pa[2] + m[6] * p0 + m[7] * p1 + m[8] * p2]


def _spread(members, scale):
    """Largest angle (deg) between member normals and distance (m) between member points."""
    units = []
    for y in members:
        norm = max(math.sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5]), NORMAL_NORM_MIN)
        units.append((y[3] / norm, y[4] / norm, y[5] / norm))
    chord = dist = 0.0
    for i in range(len(members)):
        for j in range(i + 1, len(members)):
            chord = max(chord, math.dist(units[i], units[j]))
            dist = max(dist, math.dist(members[i][:3], members[j][:3]))
    return 2.0 * math.asin(min(chord * 0.5, 1.0)) * _DEG, dist * scale


def predict_one(predictor, values, spread: bool = True, confident_only: bool = False):
    """The answer of ``predictor`` (a ``single`` or ``committee`` LearnedPredictor) for one
    validated pair (the lists of :func:`impactnet.models.box.decision.single_pair`): a
    one-row `Contacts`, the normal spread (deg) and the point spread (m) of the committee (0
    where none answered or when not ``spread``).

    A pair without this mode's models raises UnsupportedPairError. ``confident_only`` (the
    ``auto`` chain, :mod:`impactnet.models.learned.chain`): return None where the committee is
    not confident, with the separating-axis decision of the labeller, ``(None, decision)``,
    so that the exact solver finishes from it (``(None, None)`` for a pair without ``auto``'s
    models: nothing was decided).
    """
    code = predictor.table.match_one(values[0], values[3])
    pair = predictor.runtime(code)
    if confident_only and (pair is None or pair.auto is None):
        return None, None  # no models, or no calibrated thresholds: nothing is confident
    if pair is None:
        raise UnsupportedPairError([0], [p.key for p in predictor.pairs
                                         if p.supports(predictor.mode)], predictor.mode)
    if pair.exact_only:  # the bundle's decision: the exact solver answers this pair
        return (None, None) if confident_only else (box_box_one(values), 0.0, 0.0)
    swapped = code % 2 == 1
    solved = values[3:] + values[:3] if swapped else values
    if predictor.mode == "single":
        x, to_world, _, _ = _canonical(solved, pair.inv_scale)
        y = pair.single.forward_one(x).tolist()
        point, normal, depth = _to_world(pair, y, to_world, solved[1])
        inside = pair.depth_lo <= y[6] <= pair.depth_hi
        row = [True, normal, depth, point, 0, -1, -1, -1, 1.0 if inside else 0.0, "single"]
        spread = (0.0, 0.0)
    else:
        row, spread, decision = _committee_one(pair, solved, values, swapped, confident_only,
                                               spread or confident_only)
        if row is None:  # no committee for the region, or not confident: the exact solver
            if confident_only:
                return None, decision
            return answer_one(decision), 0.0, 0.0
    if swapped:
        row[1] = [-row[1][0], -row[1][1], -row[1][2]]
        row[4], row[5], row[6] = _MIRROR_TYPE[row[4]], row[6], row[5]
        row[7] = _MIRROR_AXIS[row[7]]
    return _contacts(*row), spread[0], spread[1]


def _committee_one(pair, solved, values, swapped: bool, confident_only: bool, spread: bool):
    """(row fields, spread, decision) of the committee for one pair (``solved``: in the
    bundle's order); row None when the exact solver is to answer (a region without a
    committee; with ``confident_only``, an answer the pair's thresholds do not trust); the
    spread only if ``spread``. The pair is labelled in the request's order (``values``), so
    that ``decision`` is the exact solver's own, and the labels are mirrored into the
    bundle's order if ``swapped``; the canonical features are formed only for a row the
    experts answer."""
    colliding, axis, depth, normal, code, fa, fb, exact, unclipped, decision = label_one(values)
    if swapped:
        normal, fa, fb = [-normal[0], -normal[1], -normal[2]], fb, fa
        code, axis = _MIRROR_TYPE[code], _MIRROR_AXIS[axis]
    if not colliding:
        pa, pb = values[1], values[4]
        point = [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2])]
        return ([False, normal, 0.0, point, 0, -1, -1, axis, 1.0, "committee"], (0.0, 0.0),
                decision)
    inside = pair.depth_lo <= depth / pair.edge <= pair.depth_hi
    if exact:  # the unclipped point is exact: no committee
        if confident_only and not inside:
            return None, None, decision
        return ([True, normal, depth, unclipped, code, fa, fb, axis, 1.0 if inside else 0.0,
                 "committee"], (0.0, 0.0), decision)
    x, to_world, flip_a, flip_b = _canonical(solved, pair.inv_scale)
    region = pair.region_dict.get((code, _FLIP[flip_a][fa], _FLIP[flip_b][fb]))
    if region is None or (confident_only and code in AUTO_EXACT_TYPES):
        return None, None, decision
    members = pair.experts[region].forward_one(x).tolist()
    k = len(members)
    y = [sum(column) / k for column in zip(*members)]
    spread = _spread(members, pair.scale) if spread and k > 1 else (0.0, 0.0)
    if confident_only and (not inside or spread[0] > pair.spread_normal_max
                           or spread[1] > pair.spread_point_max):
        return None, None, decision
    point = _point_to_world(pair, y, to_world, unclipped)  # the unclipped point + residual
    return ([True, normal, depth, point, code, fa, fb, axis, 1.0 if inside else 0.0,
             "committee"], spread, decision)


def _contacts(colliding, normal, depth, point, code, feature_a, feature_b, axis, confidence,
              name) -> ct.Contacts:
    """A one-row `Contacts` from two allocations (floats and small ints), as the exact
    solver's scalar path builds it; the manifold is the point itself (count 1) or empty."""
    floats = normal + point + [depth] + (point if colliding else [0.0] * 3) + _PADDING[3:]
    floats += [depth] + _PADDING[:ct.MAX_MANIFOLD_POINTS - 1] + [confidence]
    return ct.Contacts.one_row(floats, [code, feature_a, feature_b, axis, 1 if colliding else 0],
                               colliding, name)
