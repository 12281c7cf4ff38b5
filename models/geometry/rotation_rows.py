"""Orientation inputs as rows: the error every rotation check raises, the shaping of a single
value or a batch into ``(n, *tail)`` float64 rows, and the canonical quaternion sign
(conventions: :mod:`impactnet.models.geometry.rotations`)."""
from __future__ import annotations

import numpy as np


class InvalidRotationError(ValueError):
    """An orientation input that is not a rotation.

    Attributes
    ----------
    field : str
        The offending input, e.g. ``"quaternion"``, ``"matrix"``, ``"euler"``, ``"orientation"``.
    rows : numpy.ndarray of int
        Indices of the offending rows (empty when the whole input is malformed).
    """

    def __init__(self, field, rows, reason):
        self.field = field
        self.rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        shown = ", ".join(str(int(i)) for i in self.rows[:10])
        more = f" (+{self.rows.size - 10} more)" if self.rows.size > 10 else ""
        at = f" at rows [{shown}]{more}" if self.rows.size else ""
        super().__init__(f"invalid {field}: {reason}{at}")


def as_rows(x, tail, field):
    """``x`` as a float64 array of shape ``(n, *tail)``; a single ``tail``-shaped value -> n = 1."""
    a = np.asarray(x, dtype=np.float64)
    if a.shape == tail:
        a = a[None]
    if a.ndim != len(tail) + 1 or a.shape[1:] != tail:
        want = f"{tail} or (n, {', '.join(map(str, tail))})"
        raise InvalidRotationError(field, [], f"expected shape {want}, got {np.shape(x)}")
    return a


def canonical_sign(q):
    """Rows of ``(n, 4)`` quaternions flipped to the canonical sign ``w >= 0``."""
    return q * np.where(q[:, :1] < 0.0, -1.0, 1.0)
