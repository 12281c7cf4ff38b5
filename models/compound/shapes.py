"""Generated convex shapes for compound bodies: the points of a cone frustum, a wedge and a
prism, in the body's frame (metres). Each becomes a
:class:`~impactnet.models.compound.parts.ConvexPart` (the hull of its points);
:mod:`impactnet.models.compound.scene_parts` reads their parameters from scene files.

* frustum: an N-sided section at ``centre`` (z = centre's z), its copy scaled by ``tip_scale``
  about the section's centre, ``height`` higher (negative: lower). The section is a regular
  N-gon of circumdiameter ``d`` (``base = d``, any N >= 3) or a stadium ``along x across``
  (``base = [along, across]``, N even >= 8, the twistlock head's section,
  :func:`impactnet.models.compound.crane_bodies.stadium`).
* wedge: the box ``size`` at ``centre`` with its top face sloping: full height at the end
  ``high`` (``"-x"``, ``"+x"``, ``"-y"``, ``"+y"``), ``low_height`` (0 <= low < size z) at the
  opposite end. ``low_height = 0`` is a triangular prism (a chamfer), above 0 a ramp block.
* prism: a convex polygon ``section`` (>= 3 points in order round it, either way) extruded
  over ``height`` along ``axis``, centred on ``centre``. Section coordinates are cyclic:
  (x, y) for axis z, (y, z) for axis x, (z, x) for axis y.

Each function raises ``ValueError`` with the offending parameter named first (``sides: ...``)
so that the scene parser can name the field.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compound.crane_bodies import stadium

#: Ends a wedge may stand full height at.
WEDGE_ENDS = ("-x", "+x", "-y", "+y")
#: Prism axes and the body axes their section's (u, v) coordinates map to (cyclic).
PRISM_AXES = {"x": (1, 2, 0), "y": (2, 0, 1), "z": (0, 1, 2)}
#: A prism's section turns at each corner by more than this fraction of the product of the two
#: edge lengths (|sin| of the turning angle): 1e-9, far above round-off, far below a 256-gon's
#: 0.025 rad.
SECTION_TURN_TOL = 1e-9


def regular_polygon(diameter: float, sides: int) -> np.ndarray:
    """``sides`` corners of a regular polygon of circumdiameter ``diameter``, counter-clockwise
    from +x, shape (sides, 2), metres."""
    if sides < 3:
        raise ValueError(f"sides: a polygon needs >= 3 sides, got {sides}")
    angles = 2.0 * math.pi * np.arange(sides) / sides
    return 0.5 * diameter * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def frustum_points(base, sides: int, height: float, tip_scale: float = 1.0,
                   centre=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The corners of a frustum (module docstring), shape (2 * sides, 3), metres."""
    if height == 0.0:
        raise ValueError("height: must not be 0 (a frustum of no height is flat)")
    if isinstance(base, int | float):
        section = regular_polygon(float(base), sides)
    else:
        try:
            section = stadium(float(base[0]), float(base[1]), sides)
        except ValueError as exc:
            raise ValueError(f"sides: {exc}") from None
    x, y, z = centre
    low = np.column_stack([x + section[:, 0], y + section[:, 1], np.full(sides, z)])
    high = np.column_stack([x + tip_scale * section[:, 0], y + tip_scale * section[:, 1],
                            np.full(sides, z + height)])
    return np.concatenate([low, high])


def wedge_points(size, centre=(0.0, 0.0, 0.0), high: str = "-x",
                 low_height: float = 0.0) -> np.ndarray:
    """The corners of a wedge (module docstring), shape (6, 3) or (8, 3), metres."""
    if high not in WEDGE_ENDS:
        raise ValueError(f"high: expected one of {', '.join(WEDGE_ENDS)}, got {high!r}")
    size, centre = np.asarray(size, np.float64), np.asarray(centre, np.float64)
    if not 0.0 <= low_height < size[2]:
        raise ValueError(f"low_height: need 0 <= low_height < size[2] = {size[2]:g}, got "
                         f"{low_height:g}")
    axis, sign = (0 if high[1] == "x" else 1), (1.0 if high[0] == "+" else -1.0)
    corners = np.array([[x, y, -1.0] for x in (-1, 1) for y in (-1, 1)])
    bottom = centre + 0.5 * corners * size
    top_high = bottom[corners[:, axis] == sign] + (0.0, 0.0, size[2])
    parts = [bottom, top_high]
    if low_height > 0.0:
        parts.append(bottom[corners[:, axis] != sign] + (0.0, 0.0, low_height))
    return np.concatenate(parts)


def prism_points(section, height: float, axis: str = "z",
                 centre=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The corners of a prism (module docstring), shape (2 * len(section), 3), metres."""
    if axis not in PRISM_AXES:
        raise ValueError(f"axis: expected one of {', '.join(PRISM_AXES)}, got {axis!r}")
    if height <= 0.0:
        raise ValueError(f"height: must be > 0, got {height:g}")
    section = np.asarray(section, np.float64)
    if section.ndim != 2 or section.shape[1] != 2 or len(section) < 3:
        raise ValueError("section: expected >= 3 points [u, v]")
    _check_convex_section(section)
    u, v, w = PRISM_AXES[axis]
    points = np.zeros((2 * len(section), 3))
    for k, offset in enumerate((-0.5 * height, 0.5 * height)):
        rows = slice(k * len(section), (k + 1) * len(section))
        points[rows, u], points[rows, v], points[rows, w] = section[:, 0], section[:, 1], offset
    return points + np.asarray(centre, np.float64)


def _check_convex_section(section: np.ndarray) -> None:
    """Refuse a section that does not go round a convex polygon in order."""
    edges = np.roll(section, -1, axis=0) - section
    lengths = np.linalg.norm(edges, axis=1)
    if (lengths == 0.0).any():
        k = (int(np.argmax(lengths == 0.0)) + 1) % len(section)
        raise ValueError(f"section[{k}]: repeats the point before it")
    following = np.roll(edges, -1, axis=0)
    norms = lengths * np.roll(lengths, -1)
    turns = (edges[:, 0] * following[:, 1] - edges[:, 1] * following[:, 0]) / norms  # sines
    sign = 1.0 if turns.sum() > 0 else -1.0
    bad = np.flatnonzero(sign * turns <= SECTION_TURN_TOL)
    if bad.size:
        raise ValueError(f"section[{(int(bad[0]) + 1) % len(section)}]: does not turn the "
                         "same way as the others (the points must go round a convex polygon "
                         "in order, without collinear points)")
    winding = np.arctan2(turns, np.einsum("ij,ij->i", edges, following) / norms)
    if abs(abs(winding.sum()) - 2.0 * math.pi) > 1e-6:
        raise ValueError("section: the points go round more than once (a star, not a convex "
                         "polygon)")
