"""The compound oracle's result types: the ragged part contacts of N poses
(:class:`PartContacts`) and their body-level summary (:class:`BodySummary`); re-exported by
:mod:`impactnet.models.compound.oracle` and :mod:`impactnet.models.compound.summary`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.contacts import Contacts


@dataclass(frozen=True)
class PartContacts:
    """The part contacts of N poses of a pair of compound bodies, pose-major (k rows)."""

    pose: np.ndarray  # (k,) int64, the pose of each contact
    part_a: np.ndarray  # (k,) int16, index into body A's parts
    part_b: np.ndarray  # (k,) int16, index into body B's parts
    contacts: Contacts  # k rows: the exact contact of each part pair, world frame
    offsets: np.ndarray  # (n + 1,) int64: pose i's contacts are rows offsets[i]:offsets[i+1]

    def of_pose(self, i: int) -> slice:
        """The rows of pose ``i``."""
        return slice(int(self.offsets[i]), int(self.offsets[i + 1]))


@dataclass(frozen=True)
class BodySummary:
    """The summary of N poses (arrays of n rows; zeros where a pose has no contact)."""

    colliding: np.ndarray  # (n,) bool: at least one part contact
    normal: np.ndarray  # (n, 3) unit, from A towards B
    depth: np.ndarray  # (n,) metres, the deepest part contact's
    point: np.ndarray  # (n, 3) metres, world frame
    cluster_size: np.ndarray  # (n,) int: part contacts in the cluster


def made(cls, fields: dict):
    """An instance of a dataclass from its fields, without ``__init__`` (a single pose's answer
    is built from a dozen arrays: each constructor call is a measurable share of it)."""
    instance = object.__new__(cls)
    instance.__dict__.update(fields)
    return instance
