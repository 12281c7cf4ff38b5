"""One compound pair's labelled rows, split, with the arrays every stage needs.

Rows are the oracle's first-contact rows of
:func:`impactnet.training.data.compound_data.compound_rows` (A at the origin, unrotated), split into
training, validation and held-out rows by a seeded permutation (:data:`SPLIT`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.geometry.rotations import quaternion_to_matrix
from impactnet.models.learned.compound.regions import coarse_regions

#: Shares of the rows for training and validation; the rest is held out (test).
SPLIT = (0.7, 0.15)


@dataclass(frozen=True)
class CompoundRows:
    """Labelled poses of one compound pair (A at the origin, unrotated)."""

    position: np.ndarray  # (n, 3) B's origin, metres
    quaternion: np.ndarray  # (n, 4) B's orientation (w, x, y, z)
    rotation: np.ndarray  # (n, 3, 3)
    pose: np.ndarray  # (c,) the pose of each part contact
    part_a: np.ndarray  # (c,) A's part of each part contact
    part_b: np.ndarray  # (c,) B's part
    contact: dict  # per part contact: point (c, 3), normal (c, 3), depth (c,), pressure (c,),
    # type (c,), feature_a (c,), feature_b (c,)
    region: np.ndarray  # (c,) the coarse region code of each part contact
    train: np.ndarray  # pose indices for training
    val: np.ndarray  # pose indices for validation (calibration, expert choice)
    test: np.ndarray  # held-out pose indices (the figures and the decision)

    def __len__(self) -> int:
        return len(self.position)

    def contacts_of(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(contacts (c,): the part contacts of ``poses`` (indices into the rows), in row
        order; their pose (c,) as an index into ``poses``)."""
        local = np.full(len(self), -1)
        local[poses] = np.arange(len(poses))
        mine = np.flatnonzero(local[self.pose] >= 0)
        return mine, local[self.pose[mine]]


def split_rows(data: dict, seed: int) -> CompoundRows:
    """The :class:`CompoundRows` of a pair's labelled columns (``data``, as ``compound_rows``
    returns them or as the datagen npz holds them without the ``pair{k}.`` prefix)."""
    n = len(data["push"])
    order = np.random.default_rng(seed).permutation(n)
    cut_train, cut_val = int(SPLIT[0] * n), int((SPLIT[0] + SPLIT[1]) * n)
    quaternion = np.asarray(data["quaternion_b"], np.float64)
    contact = {"point": data["contact_point"], "normal": data["contact_normal"],
               "depth": data["contact_depth"], "pressure": data["contact_pressure"],
               "type": data["contact_type"], "feature_a": data["contact_feature_a"],
               "feature_b": data["contact_feature_b"]}
    rotation = quaternion_to_matrix(quaternion)
    pose = np.repeat(np.arange(n), np.diff(data["contact_offsets"]))
    return CompoundRows(np.asarray(data["position_b"], np.float64), quaternion, rotation, pose,
                        data["contact_part_a"].astype(np.int64),
                        data["contact_part_b"].astype(np.int64), contact,
                        coarse_regions(contact["type"], contact["normal"], rotation[pose]),
                        np.sort(order[:cut_train]), np.sort(order[cut_train:cut_val]),
                        np.sort(order[cut_val:]))


def pair_columns(npz, index: int) -> dict:
    """Pair ``index``'s columns of a compound datagen npz (``pair{index}.<column>``)."""
    prefix = f"pair{index}."
    return {name[len(prefix):]: npz[name] for name in npz.files if name.startswith(prefix)}
