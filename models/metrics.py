"""The one way impactnet measures an error: the angle between two normals, and the summary of
a set of errors. Used by the evaluation, the benchmarks, the paper reproduction, training's
validation and the service's smoke test alike.

* :func:`angle_deg`: ``atan2(|a x b|, a . b)`` in degrees, accurate down to round-off for tiny
  angles (``arccos`` of the dot product loses everything below ~1e-8 rad) and for angles near
  180 degrees.
* :func:`summarise`: median, mean, 90th, 95th and 99th percentiles and maximum of the finite
  values; None for each when there are none.
"""
from __future__ import annotations

import numpy as np

#: Percentiles reported by :func:`summarise` (besides the mean and the maximum).
PERCENTILES = {"median": 50.0, "p90": 90.0, "p95": 95.0, "p99": 99.0}


def angle_deg(a, b) -> np.ndarray:
    """Angles between the rows of ``a`` and ``b``, degrees.

    Parameters
    ----------
    a, b : array_like, shape (n, 3) or (3,)
        Directions (need not be unit length; zero vectors give 0).

    Returns
    -------
    ndarray, shape (n,) (or a 0-d array for two single vectors)
        In [0, 180].
    """
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.einsum("...i,...i->...", a, b)))


def summarise(values) -> dict[str, float | None]:
    """Median, mean, p90, p95, p99 and max of the finite entries of ``values`` (any shape).

    Returns
    -------
    dict
        Keys ``median``, ``mean``, ``p90``, ``p95``, ``p99``, ``max``: floats, or None each when
        no entry is finite.
    """
    values = np.asarray(values, np.float64).ravel()
    values = values[np.isfinite(values)]
    if values.size == 0:
        return {"median": None, "mean": None, **{k: None for k in PERCENTILES if k != "median"},
                "max": None}
    stats = dict(zip(PERCENTILES, np.percentile(values, list(PERCENTILES.values())).tolist()))
    return {"median": stats["median"], "mean": float(values.mean()),
            **{k: v for k, v in stats.items() if k != "median"}, "max": float(values.max())}
