"""The body-level summary of a compound contact (DESIGN.md), vectorised over poses.

Per pose with at least one part contact:

* the deepest part contact sets the ``depth`` and the reference normal;
* the cluster: the part contacts whose normals lie within :data:`CLUSTER_ANGLE_DEG` of that
  normal (the deepest included);
* ``normal``: the cluster's normals weighted by each contact's pressure integral
  ``int (d + tau) dA`` (``Contacts.pressure``), summed and normalised;
* ``point``: the cluster's points, weighted the same way.

A cluster of edge-edge contacts only (zero area, so zero weight) is weighted equally. Where two
opposing clusters tie (a twistlock touching both sides of its aperture), the summary follows the
deeper one and flips where their depths swap: that is documented behaviour, and the list of
part contacts is the continuous answer.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.oracle import PartContacts
from impactnet.models.metrics import angle_deg

#: Part contacts whose normals lie within this angle (degrees) of the deepest contact's normal
#: push the same way and are summed: far wider than a stack's tilt (milliradians), far
#: narrower than the 90 degrees between a guide's side and its chamfer or the 180 degrees
#: between the two sides of an aperture.
CLUSTER_ANGLE_DEG = 10.0


@dataclass(frozen=True)
class BodySummary:
    """The summary of N poses (arrays of n rows; zeros where a pose has no contact)."""

    colliding: np.ndarray  # (n,) bool: at least one part contact
    normal: np.ndarray  # (n, 3) unit, from A towards B
    depth: np.ndarray  # (n,) metres, the deepest part contact's
    point: np.ndarray  # (n, 3) metres, world frame
    cluster_size: np.ndarray  # (n,) int: part contacts in the cluster


def summarise(found: PartContacts) -> BodySummary:
    """The :class:`BodySummary` of each pose of ``found`` (module docstring)."""
    n = len(found.offsets) - 1
    c = found.contacts
    counts = np.diff(found.offsets)
    hit = counts > 0
    # the deepest row of each pose: rows are pose-major, so sort by (pose, -depth)
    order = np.lexsort((-c.depth, found.pose))
    deepest = np.full(n, -1, np.int64)
    deepest[hit] = order[found.offsets[:-1][hit]]
    reference = c.normal[deepest[found.pose]]
    cluster = angle_deg(c.normal, reference) <= CLUSTER_ANGLE_DEG
    weight = np.where(cluster, c.pressure, 0.0)
    total = np.bincount(found.pose, weight, minlength=n)
    equal = hit & ~(total > 0.0)  # edge-edge only: equal weights
    weight = np.where(cluster & equal[found.pose], 1.0, weight)
    total = np.bincount(found.pose, weight, minlength=n)
    safe = np.where(total > 0.0, total, 1.0)
    point = np.stack([np.bincount(found.pose, weight * c.point[:, k], minlength=n)
                      for k in range(3)], axis=1) / safe[:, None]
    pushed = np.stack([np.bincount(found.pose, weight * c.normal[:, k], minlength=n)
                       for k in range(3)], axis=1)
    length = np.linalg.norm(pushed, axis=1)
    normal = np.where(hit[:, None], pushed / np.where(length > 0.0, length, 1.0)[:, None], 0.0)
    depth = np.zeros(n)
    depth[hit] = c.depth[deepest[hit]]
    size = np.bincount(found.pose, cluster.astype(np.int64), minlength=n)
    return BodySummary(hit, normal, depth, point, size)
