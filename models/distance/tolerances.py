"""The distance query's tolerances, in one place.

Every length tolerance is relative to the *pair scale* ``s``: the larger of the two hulls'
largest half-extents (metres, :attr:`impactnet.models.compound.hull.Hull.half_extent`), so that
a pair answers the same at every size; the query works in A's frame, so the distance from the
world origin does not enter (only B's offset from A, through :data:`DIRECTION_NOISE`).
"""
from __future__ import annotations

import numpy as np

#: GJK stops when an iteration would shorten ``|v|^2`` by less than this fraction of it
#: (``|v|^2 - v . w <= GJK_PROGRESS_REL |v|^2``, dimensionless). On polytopes GJK ends first on
#: a repeated support pair; this bound only stops rounding-level cycling, and the distance it
#: can leave is at most this times the distance (1e-14 m at 1 m).
GJK_PROGRESS_REL = 1e-14
#: Iterations of GJK at most: it ends on polytopes after a few (each one adds a new support
#: pair and shortens ``v``); measured on 1,000 random poses a kind: mean 4.1 (box-box) to 6.4
#: (box against a 128-sided frustum), at most 17, so the cap only bounds a row's time if
#: rounding cycled.
GJK_MAX_ITERATIONS = 64
#: Two hulls closer than this (x pair scale, metres) touch: the row is colliding, distance 0.
#: Far above the rounding of GJK's ``v`` (1e-16 of the coordinates), far below any gap a crane
#: simulator resolves (1e-12 of a 6 m container is 6e-12 m).
TOUCH_REL = 1e-12
#: A simplex whose squared area (or volume) falls below this fraction of the product of its
#: squared edges (dimensionless, a squared sine) is flat: its lower sub-simplices answer.
FLAT_SIMPLEX_REL = 1e-24
#: Support sets (x pair scale, metres): a vertex within this of the extreme along the closest
#: direction is part of the closest region. Far above the rounding of ``n . x`` (1e-16 of the
#: scale) and of GJK's direction; far below any real feature: adjacent vertices of a 128-sided
#: frustum's cap differ by 1.2e-3 of its radius along the cap's normal. Faces within about
#: this angle (radians, x scale / face size) of parallel count as parallel.
SUPPORT_REL = 1e-9
#: In the plane across the closest direction (x pair scale, metres): projected points within
#: this of a hull edge's line are not corners, and the shadows are intersected with their
#: sides pushed out by it, so that regions meeting along an edge or at a corner still meet.
#: Far above the rounding of the projected coordinates (1e-16 of their magnitude), and small,
#: because a corner region grows by it over the sine of the angle between the sides that meet.
PLANE_REL = 1e-12
#: Relative rounding of GJK's ``v`` (dimensionless, x the coordinates' magnitude ``reach``: both
#: hulls' reach from their origins plus B's offset): a closest direction found from a short
#: ``v`` (not a face's normal) is off by up to this x reach / distance radians, which moves
#: the support height of a corner up to 2 scales away by twice that x scale; the support slack
#: grows by it, so that a flat face approached to a few nanometres still counts whole. 8 ulps
#: (GJK's ``v`` is a weighted sum of at most three support differences).
DIRECTION_NOISE = 8.0 * float(np.finfo(np.float64).eps)
#: The support slack's growth stops at this (x pair scale, metres): below ~1e-10 of the scale
#: the closest direction of an edge or vertex feature is noise and the region is what the
#: slack makes it (the distance stays exact).
SUPPORT_CAP_REL = 1e-3
#: An intersection polygon whose area is below this many times the plane slack x its diameter (m^2)
#: is a segment (two regions meeting along an edge): its midpoint answers, not its area centroid,
#: whose formula would divide rounding by a vanishing area.
THIN_AREA_FACTOR = 4.0
