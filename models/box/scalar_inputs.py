"""Validation of one pair's inputs as plain Python floats (the N = 1 fast paths' entry).

:func:`single_pair` turns the six inputs of one valid pair into float lists (quaternions
normalised) and returns None for anything else, so that the vectorised path, which
broadcasts, validates and raises the precise error, takes it.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry.rotations import QUATERNION_MIN_NORM

#: Widths of the six inputs, in ``box_box`` order.
_WIDTHS = (3, 3, 4, 3, 3, 4)


def _unit_quaternion(value):
    """A finite quaternion list normalised, or None if its norm is below the minimum (the norm
    summed in the batch path's order)."""
    w, x, y, z = value
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    return [w / norm, x / norm, y / norm, z / norm] if norm >= QUATERNION_MIN_NORM else None


def _flat_floats(value):
    """A vector as a list of floats: lists and 1-D arrays directly, anything else via NumPy."""
    if type(value) is list and all(type(v) is float for v in value):
        return value
    if type(value) in (list, tuple) and len(value) > 4:  # a batch
        return None
    if type(value) is np.ndarray:
        if value.size > 4:  # a batch: never converted element by element
            return None
        if value.ndim == 1 and value.dtype == np.float64:
            return value.tolist()
    try:
        return np.asarray(value, dtype=np.float64).reshape(-1).tolist()
    except (TypeError, ValueError):
        return None


def single_pair(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
    """The six inputs of one pair as validated float lists, or None.

    None means "not a single valid pair": the caller then takes the vectorised path, which
    broadcasts, validates and raises the precise error. The common shapes (float64 vectors,
    float lists) are checked without a per-element loop; finiteness by one sum (a sum that
    overflows declines a valid pair, which the vectorised path then answers).
    """
    rows = []
    for value, width in zip((size_a, position_a, quaternion_a, size_b, position_b,
                             quaternion_b), _WIDTHS):
        if type(value) is np.ndarray and value.shape == (width,) and value.dtype == np.float64:
            row = value.tolist()
        else:
            row = _flat_floats(value)
        if row is None or len(row) != width:
            return None
        rows.append(row)
    size_a, pa, qa, size_b, pb, qb = rows
    if not math.isfinite(sum(size_a) + sum(pa) + sum(qa) + sum(size_b) + sum(pb) + sum(qb)):
        return None
    for sizes in (size_a, size_b):
        if not (min(sizes) >= SIZE_MIN_M and max(sizes) <= SIZE_MAX_M):
            return None
    for p in (pa, pb):
        if not (abs(p[0]) <= POSITION_MAX_M and abs(p[1]) <= POSITION_MAX_M
                and abs(p[2]) <= POSITION_MAX_M):
            return None
    rows[2], rows[5] = _unit_quaternion(qa), _unit_quaternion(qb)
    return None if rows[2] is None or rows[5] is None else rows
