"""First-contact poses of compound bodies (issue #20, step 5), vectorised over poses.

Each family places body B near body A (A at the origin, unrotated), moves B along an approach
direction until it first touches A (bisection on the compound oracle's answer), then pushes it
on by a depth drawn from the scene's range. Families (B relative to A):

* ``stacking``: B on top of A, castings nearly aligned: offsets of a few centimetres, a yaw of
  a fraction of a degree, a tilt about a random horizontal axis (log-uniform, down to 1e-6
  rad), lowered vertically;
* ``near_stacking``: the same with offsets up to a casting's size and yaws up to 2 degrees,
  so castings overlap in part or miss;
* ``twistlock_entry``: a spreader B lowered onto a container A, its twistlocks within a few
  centimetres of the apertures' centres, slightly tilted;
* ``guide_sliding``: a container B beside a cell guide A, pushed horizontally towards the
  guide's angle or its entry at a random height, slightly yawed and tilted.

Depth pushes are along the approach direction, so the oracle's depth is close to, not equal
to, the push; the dataset keeps the oracle's answer (:mod:`impactnet.training.data.compound_data`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.oracle import compound_touching

#: Bisection steps of the first contact: halving a bracket of :data:`APPROACH_RANGE_M` this
#: many times leaves 0.5 m / 2**30, 0.5 nm, far below any pushed depth.
BISECTION_STEPS = 30
#: Distance along the approach direction over which the first contact is searched (m): the
#: start is this far back from the nominal touching pose.
APPROACH_RANGE_M = 0.5
FAMILIES = ("stacking", "near_stacking", "twistlock_entry", "guide_sliding")


@dataclass(frozen=True)
class PoseFamily:
    """Where B starts relative to A, and the direction it approaches along."""

    name: str  # one of FAMILIES
    offset_m: tuple[float, float, float]  # half-width of the uniform start offsets (x, y, z)
    yaw_rad: float  # half-width of the uniform yaw about z
    tilt_rad: tuple[float, float]  # log-uniform tilt about a random horizontal axis (lo, hi)


#: The families' parameters (named in the module docstring).
FAMILY_PARAMETERS = {
    "stacking": PoseFamily("stacking", (0.05, 0.05, 0.0), 2e-3, (1e-6, 1e-2)),
    "near_stacking": PoseFamily("near_stacking", (0.18, 0.16, 0.0), 0.035, (1e-6, 2e-2)),
    "twistlock_entry": PoseFamily("twistlock_entry", (0.015, 0.006, 0.0), 5e-3, (1e-6, 1e-2)),
    "guide_sliding": PoseFamily("guide_sliding", (0.0, 0.02, 1.0), 0.01, (1e-6, 5e-3)),
}


def _orientations(rng, n: int, family: PoseFamily) -> np.ndarray:
    """Quaternions (n, 4): a yaw, then a tilt about a random horizontal axis."""
    yaw = rng.uniform(-family.yaw_rad, family.yaw_rad, n)
    lo, hi = np.log(family.tilt_rad[0]), np.log(family.tilt_rad[1])
    tilt = np.exp(rng.uniform(lo, hi, n))
    heading = rng.uniform(0, 2 * np.pi, n)
    q_yaw = np.c_[np.cos(yaw / 2), np.zeros((n, 2)), np.sin(yaw / 2)]
    q_tilt = np.c_[np.cos(tilt / 2), np.sin(tilt / 2)[:, None]
                   * np.c_[np.cos(heading), np.sin(heading), np.zeros(n)]]
    return _multiply(q_tilt, q_yaw)


def _multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton products p q of quaternions (n, 4), (w, x, y, z)."""
    w1, x1, y1, z1 = p.T
    w2, x2, y2, z2 = q.T
    return np.c_[w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                 w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2]


def first_contact(parts_a, parts_b, start: np.ndarray, quaternion: np.ndarray,
                  direction: np.ndarray) -> np.ndarray:
    """How far along ``direction`` (n, 3) unit each B, starting at ``start`` (n, 3), moves
    until it first touches A (at the origin); (n,) metres, NaN where it never touches within
    :data:`APPROACH_RANGE_M` beyond the nominal pose (2 x the range in all)."""
    n = len(start)
    origin, identity = np.zeros((n, 3)), np.tile([1.0, 0, 0, 0], (n, 1))

    def touching(distance):  # the separating-axis test alone: the oracle's touching poses
        return compound_touching(parts_a, origin, identity, parts_b,
                                 start + distance[:, None] * direction, quaternion)

    lo, hi = np.zeros(n), np.full(n, 2 * APPROACH_RANGE_M)
    reach = touching(hi)
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        hit = touching(mid)
        hi, lo = np.where(hit, mid, hi), np.where(hit, lo, mid)
    return np.where(reach & ~touching(np.zeros(n)), hi, np.nan)


def family_poses(family: str, parts_a, parts_b, nominal: np.ndarray, approach: np.ndarray,
                 depth_range_m: tuple[float, float], n: int, rng: np.random.Generator):
    """n poses of B against A of one family.

    Parameters
    ----------
    family : str
        One of :data:`FAMILIES`.
    parts_a, parts_b : tuple of Part
        The bodies (A at the origin, unrotated).
    nominal : ndarray, shape (3,)
        B's position where it would just touch A without offsets (metres).
    approach : ndarray, shape (3,)
        Unit direction in which B moves towards A.
    depth_range_m : (float, float)
        Pushes past the first contact (metres).

    Returns
    -------
    position (n, 3), quaternion (n, 4), push (n,): the pushed poses; rows whose first contact
    was not found are dropped (fewer than n rows).
    """
    spec = FAMILY_PARAMETERS[family]
    quaternion = _orientations(rng, n, spec)
    offset = rng.uniform(-1.0, 1.0, (n, 3)) * np.asarray(spec.offset_m)
    approach = np.asarray(approach, float) / np.linalg.norm(approach)
    offset -= (offset @ approach)[:, None] * approach  # offsets across the approach only
    start = np.asarray(nominal, float) + offset - APPROACH_RANGE_M * approach
    direction = np.tile(approach, (n, 1))
    distance = first_contact(parts_a, parts_b, start, quaternion, direction)
    push = rng.uniform(*depth_range_m, n)
    keep = np.isfinite(distance)
    position = start + (np.nan_to_num(distance) + push)[:, None] * direction
    return position[keep], quaternion[keep], push[keep]
