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


def _unit_quaternion(value):
    """A finite quaternion list normalised, or None if its norm is below the minimum."""
    norm = math.sqrt(sum(v * v for v in value))
    return [v / norm for v in value] if norm >= QUATERNION_MIN_NORM else None


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
    broadcasts, validates and raises the precise error.
    """
    values = []
    for value, width in ((size_a, 3), (position_a, 3), (quaternion_a, 4), (size_b, 3),
                         (position_b, 3), (quaternion_b, 4)):
        row = _flat_floats(value)
        if row is None or len(row) != width or not all(math.isfinite(v) for v in row):
            return None
        values.append(row)
    for sizes in (values[0], values[3]):
        if not (min(sizes) >= SIZE_MIN_M and max(sizes) <= SIZE_MAX_M):
            return None
    for position in (values[1], values[4]):
        if max(abs(v) for v in position) > POSITION_MAX_M:
            return None
    values[2], values[5] = _unit_quaternion(values[2]), _unit_quaternion(values[5])
    return None if values[2] is None or values[5] is None else values
