"""Detail level 2 of a container's corners: the top corner casting with its aperture, as convex
pieces, and the body split so that the castings' cavities stay free (issue #20, step 1).

The top aperture (ISO 1161) is an oval of :data:`~.crane_bodies.APERTURE_DIAMETER` cut by
flats :data:`~.crane_bodies.APERTURE_FLATS` apart, long axis along the container. As a polygon
its two arcs have :data:`ARC_SEGMENTS` chords each (the chords' sag, 0.56 mm with 4, is the
only approximation). The top plate around it, :data:`TOP_PLATE_ASSUMED` thick, is cut into
one convex piece per polygon edge: the plate's rectangle within the wedge that the edge spans
seen from the aperture's centre, beyond the edge. The pieces tile the ring without overlap,
so their contacts add up to the ring's centre of pressure.

Below the plate the casting is hollow (the cavity a twistlock head turns in): four walls and a
floor, :data:`WALL_ASSUMED` thick. The container's body is three boxes that leave the corner
columns to the castings and a corner post between them, so nothing fills the cavity.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compound.parts import BoxPart, ConvexPart, Part

#: Chords per arc of the aperture's polygon (its sag: r (1 - cos(alpha / ARC_SEGMENTS))).
ARC_SEGMENTS = 4
#: Thickness of the top casting's top plate around the aperture (m): an assumption (ISO 1161
#: fixes the aperture, not the wall; cast fittings have 25-30 mm).
TOP_PLATE_ASSUMED = 0.026
#: Thickness of the top casting's walls and floor around the cavity (m): an assumption.
WALL_ASSUMED = 0.020


def aperture_polygon(diameter: float, flats: float, segments: int = ARC_SEGMENTS) -> np.ndarray:
    """The aperture's oval as a convex polygon, counter-clockwise, centred at the origin,
    long axis along x: shape (2 segments + 2, 2), metres."""
    radius = diameter / 2
    alpha = math.asin(flats / diameter)
    right = np.linspace(-alpha, alpha, segments + 1)
    angles = np.concatenate([right, right + math.pi])
    return radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def _clip(polygon: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """The part of a convex polygon (k, 2) where ``normal . x <= offset``."""
    out = []
    for k in range(len(polygon)):
        p, q = polygon[k], polygon[(k + 1) % len(polygon)]
        dp, dq = normal @ p - offset, normal @ q - offset
        if dp <= 0:
            out.append(p)
        if (dp < 0) != (dq < 0) and dp != dq:
            out.append(p + dp / (dp - dq) * (q - p))
    return np.array(out)


def ring_pieces(half: np.ndarray, hole: np.ndarray) -> list[np.ndarray]:
    """The convex pieces (each (k, 2), counter-clockwise) of the rectangle ``|x| <= half``
    without the convex ``hole`` (h, 2), which contains the origin: one per hole edge."""
    rectangle = np.array([[half[0], half[1]], [-half[0], half[1]], [-half[0], -half[1]],
                          [half[0], -half[1]]])
    pieces = []
    for k in range(len(hole)):
        p, q = hole[k], hole[(k + 1) % len(hole)]
        piece = rectangle
        for side, point in ((1.0, p), (-1.0, q)):  # the wedge from the centre through p, q
            piece = _clip(piece, side * np.array([point[1], -point[0]]), 0.0)
        edge = q - p
        piece = _clip(piece, np.array([-edge[1], edge[0]]), edge[0] * p[1] - edge[1] * p[0])
        pieces.append(piece)
    return pieces


def top_casting(prefix: str, centre, size, aperture_offset, diameter, flats) -> list[Part]:
    """The pieces of one top casting, named ``prefix/...`` (one broadphase group).

    Parameters
    ----------
    prefix : str
        Group name, e.g. ``casting_top_fl``.
    centre, size : sequence of float
        The casting's box (m), body frame.
    aperture_offset : sequence of float
        The aperture's centre minus the casting's, (x, y), metres.
    diameter, flats : float
        The aperture's oval (m).
    """
    centre, size = np.asarray(centre, float), np.asarray(size, float)
    half = 0.5 * size[:2]
    offset = np.asarray(aperture_offset, float)
    top = centre[2] + 0.5 * size[2]
    plate_bottom = top - TOP_PLATE_ASSUMED
    parts: list[Part] = []
    for k, piece in enumerate(_shifted_pieces(half, offset, diameter, flats)):
        xy = piece + centre[:2]
        points = [(x, y, z) for z in (plate_bottom, top) for x, y in xy]
        parts.append(ConvexPart(f"{prefix}/ring_{k}", tuple(points)))
    parts += _cavity_walls(prefix, centre, size, plate_bottom)
    return parts


def _shifted_pieces(half, offset, diameter, flats) -> list[np.ndarray]:
    """Ring pieces of the casting's rectangle (half extents ``half``, centred at the origin)
    around an aperture at ``offset``, in the casting's coordinates."""
    shifted_half_lo, shifted_half_hi = -half - offset, half - offset
    # the rectangle relative to the aperture's centre is not symmetric: cut the symmetric
    # cover, then clip to the real sides
    cover = np.maximum(np.abs(shifted_half_lo), np.abs(shifted_half_hi))
    pieces = []
    for piece in ring_pieces(cover, aperture_polygon(diameter, flats)):
        for axis in range(2):
            normal = np.eye(2)[axis]
            piece = _clip(piece, normal, shifted_half_hi[axis])
            piece = _clip(piece, -normal, -shifted_half_lo[axis])
        pieces.append(piece + offset)
    return pieces


def _cavity_walls(prefix, centre, size, plate_bottom) -> list[Part]:
    """Four walls and a floor under the top plate, around the cavity (all boxes)."""
    lo = centre - 0.5 * size
    hi = np.array([*(centre[:2] + 0.5 * size[:2]), plate_bottom])
    t = WALL_ASSUMED
    boxes = {
        "wall_x_lo": ([lo[0], lo[1], lo[2] + t], [lo[0] + t, hi[1], hi[2]]),
        "wall_x_hi": ([hi[0] - t, lo[1], lo[2] + t], [hi[0], hi[1], hi[2]]),
        "wall_y_lo": ([lo[0] + t, lo[1], lo[2] + t], [hi[0] - t, lo[1] + t, hi[2]]),
        "wall_y_hi": ([lo[0] + t, hi[1] - t, lo[2] + t], [hi[0] - t, hi[1], hi[2]]),
        "floor": ([lo[0], lo[1], lo[2]], [hi[0], hi[1], lo[2] + t]),
    }
    return [BoxPart(f"{prefix}/{name}", tuple(float(v) for v in np.subtract(b, a)),
                    tuple(float(v) for v in 0.5 * (np.add(a, b)))) for name, (a, b) in
            boxes.items()]
