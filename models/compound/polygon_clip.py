"""Convex polygons in a plane, many at once: clipping by half-planes and the closed-form
integrals of a linear pressure over them (the convex solver's stage of the centre of pressure).

A batch of k polygons is an array ``(k, C, 3)`` of vertices ``(u, w, p)`` (in-plane coordinates
in metres and the pressure ``p``, metres of depth, linear over each polygon) in cyclic order,
with ``counts`` (k,) valid vertices each; slots past the count repeat nothing useful and are
ignored.

Clipping (:func:`clip`) is Sutherland-Hodgman on all polygons at once: each vertex slot emits
itself where it is inside and the crossing of its outgoing edge where that edge crosses the
boundary; the emitted points are compacted to the front in order (so the cyclic order holds),
slots past the count are zero.
A convex polygon cut by one half-plane gains at most one vertex.

Integrals (:func:`moments`): fan triangles from slot 0, each with the closed forms for a
linear pressure over a triangle of area S with vertices a, b, c (as in
:mod:`impactnet.models.box.pressure`)::

    int p    = S (pa + pb + pc) / 3
    int x p  = S / 12 [a (2pa + pb + pc) + b (pa + 2pb + pc) + c (pa + pb + 2pc)]
    int p^2  = S / 6 (pa^2 + pb^2 + pc^2 + pa pb + pb pc + pc pa)
"""
from __future__ import annotations

import numpy as np

#: Coordinates of a polygon vertex: in-plane u, w (metres) and the pressure p (metres).
U, W, P = range(3)


def clip(polygons: np.ndarray, counts: np.ndarray, coefficients: np.ndarray,
         pressure_plane: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Clip k convex polygons to the half-planes ``c0 u + c1 w + c2 p + c3 >= 0``.

    Parameters
    ----------
    polygons : ndarray, shape (k, C, 3)
        Vertices (u, w, p) in cyclic order.
    counts : ndarray of int, shape (k,)
        Valid vertices per polygon (0 for an empty one).
    coefficients : ndarray, shape (k, 4) or (4,)
        The half-plane of each polygon.
    pressure_plane : bool
        The half-plane is ``p >= 0``: crossings get ``p = 0`` exactly.

    Returns
    -------
    polygons : ndarray, shape (k, C', 3)
        The clipped polygons, C' the largest count after the cut.
    counts : ndarray of int, shape (k,)
    """
    k, width, _ = polygons.shape
    coefficients = np.broadcast_to(coefficients, (k, 4))
    value = (coefficients[:, None, U] * polygons[:, :, U]
             + coefficients[:, None, W] * polygons[:, :, W]
             + coefficients[:, None, P] * polygons[:, :, P] + coefficients[:, None, 3])
    slot = np.arange(width)[None, :]
    valid = slot < counts[:, None]
    if not (valid & (value < 0.0)).any():  # nothing outside: the polygons stay as they are
        return polygons, counts
    following = np.where(slot + 1 < counts[:, None], slot + 1, 0)
    nxt_value = np.take_along_axis(value, following, axis=1)
    nxt_point = np.take_along_axis(polygons, following[:, :, None], axis=1)
    inside = value >= 0.0
    crossing = valid & (inside != (nxt_value >= 0.0))
    fraction = value / np.where(crossing, value - nxt_value, 1.0)
    cut = polygons + fraction[:, :, None] * (nxt_point - polygons)
    if pressure_plane:
        cut[:, :, P] = np.where(crossing, 0.0, cut[:, :, P])
    emitted = np.stack([polygons, cut], axis=2).reshape(k, 2 * width, 3)
    keep = np.stack([valid & inside, crossing], axis=2).reshape(k, 2 * width)
    slots = np.cumsum(keep, axis=1)  # 1 + the output slot of each kept point
    new_counts = slots[:, -1]
    out = np.zeros((k, max(int(new_counts.max(initial=0)), 1), 3))
    item, source = np.nonzero(keep)
    out[item, slots[item, source] - 1] = emitted[item, source]
    return out, new_counts


def moments(polygons: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The integrals ``int p``, ``int u p``, ``int w p`` and ``int p^2`` over each polygon.

    Parameters
    ----------
    polygons : ndarray, shape (k, C, 3)
    counts : ndarray of int, shape (k,)

    Returns
    -------
    ndarray, shape (4, k)
        Units m^3, m^4, m^4, m^4 (areas in m^2 times pressures in m).
    """
    k, width, _ = polygons.shape
    out = np.zeros((4, k))
    a = polygons[:, 0]
    for i in range(1, width - 1):
        b, c = polygons[:, i], polygons[:, i + 1]
        area = 0.5 * np.abs((b[:, U] - a[:, U]) * (c[:, W] - a[:, W])
                            - (b[:, W] - a[:, W]) * (c[:, U] - a[:, U]))
        area = np.where(i + 1 < counts, area, 0.0)
        pa, pb, pc = a[:, P], b[:, P], c[:, P]
        out[0] += area * (pa + pb + pc) / 3.0
        for row, axis in ((1, U), (2, W)):
            out[row] += area / 12.0 * (a[:, axis] * (2 * pa + pb + pc)
                                       + b[:, axis] * (pa + 2 * pb + pc)
                                       + c[:, axis] * (pa + pb + 2 * pc))
        out[3] += area / 6.0 * (pa * pa + pb * pb + pc * pc + pa * pb + pb * pc + pc * pa)
    return out
