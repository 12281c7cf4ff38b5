"""The body-level summary of a compound contact (docs/design.md), compiled
(:mod:`impactnet.models.compound.kernel_summary`).

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

The oracle summarises as it solves (:mod:`impactnet.models.compound.kernel_pipeline`);
:func:`summarise` summarises part contacts from elsewhere (the learned chain's merged sources).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.kernel_summary import CLUSTER_ANGLE_DEG, summaries
from impactnet.models.compound.results import BodySummary, PartContacts

__all__ = ["CLUSTER_ANGLE_DEG", "BodySummary", "summarise"]


def summarise(found: PartContacts) -> BodySummary:
    """The :class:`BodySummary` of each pose of ``found`` (module docstring; rows pose-major,
    ``offsets`` delimiting each pose's)."""
    c = found.contacts

    def rows(values):
        return np.ascontiguousarray(values, np.float64)

    return BodySummary(*summaries(np.ascontiguousarray(found.offsets, np.int64), rows(c.depth),
                                  rows(c.normal), rows(c.point), rows(c.pressure)))
