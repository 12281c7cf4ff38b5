"""The paper's four angles of an answer (``include=paper_angles``): the azimuth and elevation, in
A's frame, of the impact point's direction from A's origin and of the force direction (the
body-level point and normal); NaN where the pair does not touch or the point sits at A's
origin."""
from __future__ import annotations

import logging

import numpy as np

from impactnet.models.dispatch import Answers, Pairs
from impactnet.models.geometry import spherical
from impactnet.models.geometry.rotations import quaternion_to_matrix

log = logging.getLogger("impactnet.service")
#: Distance (metres) from A's origin below which the impact point has no direction: 1e-12 m,
#: a millionth of the smallest accepted size (1 um).
UNDEFINED_DIRECTION_M = 1e-12


def paper_angles(answers: Answers, pairs: Pairs, start: int, stop: int) -> np.ndarray:
    """The angles (k, 4) of rows ``start:stop``, radians (module docstring)."""
    body = answers.body
    point, normal = body["point"][start:stop], body["normal"][start:stop]
    position = pairs.column("position_a")[start:stop]
    out = np.full((stop - start, 4), np.nan)
    offset = np.linalg.norm(point - position, axis=1)
    rows = np.flatnonzero(body["colliding"][start:stop] & (offset > UNDEFINED_DIRECTION_M)
                          & (np.linalg.norm(normal, axis=1) > 0.5))
    if rows.size:
        rotation = quaternion_to_matrix(pairs.column("quaternion_a")[start:stop][rows])
        try:
            out[rows] = spherical.paper_angles(point[rows], normal[rows], position[rows],
                                                rotation)
        except ValueError:  # a direction that vanished in round-off: leave those rows NaN
            log.warning("paper angles undefined", exc_info=True)
    return out
