"""Generators of the harbour's compound bodies: ISO containers with corner castings, a spreader
with twistlocks, a cell guide with its chamfered entry guide (issue #20, step 1).

Frames: x along the body's length, y across, z up; the body's centre (of its ISO envelope) at
the origin. Dimensions in metres, from the standards where they give them; the others are
assumptions, named ``*_ASSUMED`` and listed in :data:`ASSUMPTIONS`.

Containers (ISO 668:2020 table 1, external dimensions; ISO 1161:2016, corner fittings;
ISO 1496-1:2013, clearances):

* envelope ``L x W x H``: 1CC (20 ft) 6.058 x 2.438 x 2.591, 1AA (40 ft) 12.192 x 2.438 x 2.591,
  1AAA (40 ft high cube) 12.192 x 2.438 x 2.896;
* eight corner castings of 178 (along) x 162 (across) x 118 (high) mm, flush with the envelope;
* the body box between them: its roof 6 mm below the top face of the top castings, its base
  12.5 mm above the bottom face of the bottom castings, so that a container stands, and is
  stacked, on its castings alone. (ISO 1496-1 gives both figures as minima; the body uses the
  minima.)
* the top aperture of a casting, centred 101.5 mm from the end face and 89 mm from the side
  face: an oval of 124.5 mm cut by flats 63.5 mm apart (ISO 1161). Detail level 1 models the
  castings as solid boxes; level 2 (the aperture as convex pieces) comes with the convex
  solver.

Spreader: a frame box over the container's length and width and four twistlocks at the
apertures' centres. A twistlock is a shaft and an oblong head: a convex frustum whose section
is a stadium (two half-discs joined by a rectangle), approximated by ``sides`` vertices (8 to
256), widest (:data:`TWISTLOCK_HEAD_ASSUMED` 104 x 56 mm, as the issue gives it) where it
meets the shaft and narrowing towards its tip below, so that it enters the aperture. Centred in
its aperture it touches nothing (10.25 mm clearance along, 3.75 mm across).

Cell guide: a vertical angle of 150 x 150 mm, :data:`GUIDE_THICKNESS` thick, with a chamfered
entry guide on top: each leg continued by a convex leaning plate whose angle is a parameter.
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compound.casting_detail import top_casting
from impactnet.models.compound.parts import BoxPart, ConvexPart, Part, validate_parts

#: ISO 668 external dimensions (L, W, H), metres.
CONTAINERS = {"20ft": (6.058, 2.438, 2.591), "40ft": (12.192, 2.438, 2.591),
              "40ft_hc": (12.192, 2.438, 2.896)}
#: ISO 1161 corner fitting, (along, across, high), metres.
CASTING = (0.178, 0.162, 0.118)
#: ISO 1496-1: the roof at least this far below the top face of the top castings (m).
ROOF_BELOW_CASTINGS = 0.006
#: ISO 1496-1: the underside of the base at least this far above the castings' bottom (m).
BASE_ABOVE_CASTINGS = 0.0125
#: ISO 1161: the top aperture's centre from the end face and from the side face (m).
APERTURE_FROM_END, APERTURE_FROM_SIDE = 0.1015, 0.089
#: ISO 1161: the top aperture, an oval of this diameter cut by flats this far apart (m).
APERTURE_DIAMETER, APERTURE_FLATS = 0.1245, 0.0635
#: Twistlock head at its widest, (along, across) metres: the issue's figure, an assumption.
TWISTLOCK_HEAD_ASSUMED = (0.104, 0.056)
#: Twistlock head height and its tip's share of the widest section (assumptions).
TWISTLOCK_HEIGHT_ASSUMED, TWISTLOCK_TIP_SCALE_ASSUMED = 0.060, 0.5
#: Twistlock shaft (square section, length) between frame and head, metres (assumptions).
TWISTLOCK_SHAFT_ASSUMED = (0.050, 0.030)
#: Spreader frame height, metres (the box scene's spreader; an assumption).
SPREADER_FRAME_HEIGHT_ASSUMED = 0.8
#: Cell guide: the angle's legs (m), its thickness (m, 12-15 mm in the issue) and height (m).
GUIDE_LEG, GUIDE_THICKNESS, GUIDE_HEIGHT_ASSUMED = 0.150, 0.014, 6.0
#: Height of the cell guide's chamfered entry above the angle (m, an assumption).
ENTRY_RISE_ASSUMED = 0.3
#: Cell guide clearances to the container (m): across at most, along at most (issue #20).
GUIDE_CLEARANCE_ACROSS, GUIDE_CLEARANCE_ALONG = 0.025, 0.040
#: Figures that no standard fixes here.
ASSUMPTIONS = ("TWISTLOCK_HEAD_ASSUMED", "TWISTLOCK_HEIGHT_ASSUMED",
               "TWISTLOCK_TIP_SCALE_ASSUMED", "TWISTLOCK_SHAFT_ASSUMED",
               "SPREADER_FRAME_HEIGHT_ASSUMED", "GUIDE_HEIGHT_ASSUMED", "ENTRY_RISE_ASSUMED",
               "the body box at exactly the ISO 1496-1 minimum clearances")


def _corners():
    """(sx, sy, name) of the four corners."""
    return [(sx, sy, f"{'f' if sx > 0 else 'a'}{'l' if sy > 0 else 'r'}")
            for sx in (1, -1) for sy in (1, -1)]


def container(kind: str = "40ft", detail: int = 1) -> tuple[Part, ...]:
    """The parts of an ISO container (module docstring): at detail 1 the body box and 8 solid
    castings; at detail 2 the top castings with their apertures as convex pieces and hollow
    below (:mod:`impactnet.models.compound.casting_detail`)."""
    if kind not in CONTAINERS:
        raise ValueError(f"unknown container {kind!r}; choose one of {sorted(CONTAINERS)}")
    if detail not in (1, 2):
        raise ValueError(f"container detail is 1 (solid castings) or 2 (apertures), got {detail}")
    length, width, height = CONTAINERS[kind]
    top, bottom = height / 2 - ROOF_BELOW_CASTINGS, -height / 2 + BASE_ABOVE_CASTINGS
    cl, cw, ch = CASTING
    parts: list[Part] = (_split_body(length, width, top, bottom) if detail == 2 else
                         [BoxPart("body", (length, width, top - bottom),
                                  (0.0, 0.0, 0.5 * (top + bottom)))])
    for (sx, sy, corner), aperture in zip(_corners(), aperture_centres(kind)):
        x, y = sx * (length - cl) / 2, sy * (width - cw) / 2
        parts.append(BoxPart(f"casting_bottom_{corner}", CASTING, (x, y, -(height - ch) / 2)))
        centre = (x, y, (height - ch) / 2)
        if detail == 1:
            parts.append(BoxPart(f"casting_top_{corner}", CASTING, centre))
            continue
        parts += top_casting(f"casting_top_{corner}", centre, CASTING,
                             (aperture[0] - x, aperture[1] - y), APERTURE_DIAMETER,
                             APERTURE_FLATS)
        parts.append(BoxPart(f"post_{corner}", (cl, cw, height - 2 * ch), (x, y, 0.0)))
    return validate_parts(f"container {kind}", parts)


def _split_body(length, width, top, bottom) -> list[Part]:
    """The body at detail 2: a middle box between the end frames' castings and two end boxes
    between each end's castings, so that the corner columns hold only castings and posts."""
    cl, cw, _ = CASTING
    z, h = 0.5 * (top + bottom), top - bottom
    return [BoxPart("body", (length - 2 * cl, width, h), (0.0, 0.0, z)),
            BoxPart("end_front", (cl, width - 2 * cw, h), ((length - cl) / 2, 0.0, z)),
            BoxPart("end_rear", (cl, width - 2 * cw, h), (-(length - cl) / 2, 0.0, z))]


def aperture_centres(kind: str = "40ft") -> np.ndarray:
    """Centres (x, y) of the 4 top apertures of a container, shape (4, 2), metres."""
    length, width, _ = CONTAINERS[kind]
    return np.array([(sx * (length / 2 - APERTURE_FROM_END), sy * (width / 2 - APERTURE_FROM_SIDE))
                     for sx, sy, _ in _corners()])


def stadium(along: float, across: float, sides: int) -> np.ndarray:
    """A stadium section (two half-discs of diameter ``across`` joined by straight sides) as
    ``sides`` points on it (x along, y across), counter-clockwise, shape (sides, 2), metres;
    with few sides the caps' polygons are stretched along x so that the section spans exactly
    ``along`` x ``across``."""
    if sides < 8 or sides % 2:
        raise ValueError(f"a stadium needs an even number of sides >= 8, got {sides}")
    radius, half = across / 2, max(along - across, 0.0) / 2
    per_end = sides // 2
    angles = np.linspace(-math.pi / 2, math.pi / 2, per_end)
    right = np.stack([half + radius * np.cos(angles), radius * np.sin(angles)], axis=1)
    right[:, 0] *= (along / 2) / right[:, 0].max()  # the polygon spans exactly `along`
    return np.concatenate([right, -right])


def twistlock_head(centre_xy, top_z: float, sides: int, name: str) -> ConvexPart:
    """The head of a twistlock: a stadium frustum from ``top_z`` (widest) down to its tip."""
    along, across = TWISTLOCK_HEAD_ASSUMED
    widest = stadium(along, across, sides)
    tip = TWISTLOCK_TIP_SCALE_ASSUMED * widest
    x, y = centre_xy
    points = [(x + u, y + w, top_z) for u, w in widest]
    points += [(x + u, y + w, top_z - TWISTLOCK_HEIGHT_ASSUMED) for u, w in tip]
    return ConvexPart(name, tuple(points))


def spreader(kind: str = "40ft", sides: int = 32) -> tuple[Part, ...]:
    """The parts of a spreader set for a container of ``kind``: the frame box (the body frame's
    origin at its centre) and four twistlocks (shaft and head) below it at the apertures'
    centres; ``sides`` vertices per stadium section of a head (the detail parameter)."""
    length, width, _ = CONTAINERS[kind]
    frame_h = SPREADER_FRAME_HEIGHT_ASSUMED
    parts: list[Part] = [BoxPart("frame", (length, width, frame_h))]
    shaft_side, shaft_len = TWISTLOCK_SHAFT_ASSUMED
    underside = -frame_h / 2
    for (x, y), (_, _, corner) in zip(aperture_centres(kind), _corners()):
        parts.append(BoxPart(f"shaft_{corner}", (shaft_side, shaft_side, shaft_len),
                             (x, y, underside - shaft_len / 2)))
        parts.append(twistlock_head((x, y), underside - shaft_len, sides, f"head_{corner}"))
    return validate_parts(f"spreader {kind}", parts)


def _leaning_plate(name: str, x0: float, x1: float, y0: float, y1: float, z: float,
                   shift: tuple[float, float]) -> ConvexPart:
    """A plate's top face (x0..x1, y0..y1 at height z) swept up by ENTRY_RISE_ASSUMED while
    shifting by ``shift`` (dx, dy): a parallelepiped, convex."""
    base = [(x, y) for x in (x0, x1) for y in (y0, y1)]
    dx, dy = shift
    points = [(x, y, z) for x, y in base] + [(x + dx, y + dy, z + ENTRY_RISE_ASSUMED)
                                             for x, y in base]
    return ConvexPart(name, tuple(points))


def cell_guide(entry_angle_deg: float = 30.0) -> tuple[Part, ...]:
    """A cell guide: the 150 x 150 mm angle (legs along +x and +y from the body origin's
    vertical edge; the cell lies at x, y > thickness) and its entry guide on top: each leg
    continued upwards by :data:`ENTRY_RISE_ASSUMED`, leaning away from the cell at
    ``entry_angle_deg`` from the vertical, so that a container coming down slides in."""
    if not 0.0 < entry_angle_deg < 90.0:
        raise ValueError(f"entry angle must be in (0, 90) degrees, got {entry_angle_deg}")
    leg, t, h = GUIDE_LEG, GUIDE_THICKNESS, GUIDE_HEIGHT_ASSUMED
    lean = ENTRY_RISE_ASSUMED * math.tan(math.radians(entry_angle_deg))
    parts: list[Part] = [
        BoxPart("leg_x", (leg, t, h), (leg / 2, t / 2, 0.0)),
        BoxPart("leg_y", (t, leg - t, h), (t / 2, t + (leg - t) / 2, 0.0)),
        _leaning_plate("entry_x", 0.0, leg, 0.0, t, h / 2, (0.0, -lean)),
        _leaning_plate("entry_y", 0.0, t, t, leg, h / 2, (-lean, 0.0)),
    ]
    return validate_parts("cell guide", parts)
