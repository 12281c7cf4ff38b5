"""The served committee expert of one contact region of a compound pair (issue #21, step 2).

A region is a part pair (A's part, B's part) and a coarse region of its contact (contact type
and the two parts' bounding-box faces, :mod:`impactnet.models.learned.compound.regions`), as
the classifier names them: it does not grow with the parts' detail. Training
(:mod:`impactnet.training.compound.experts`) chooses, by measurement, a committee of K MLPs or
the exact part-pair solver for each region; only the committees are served here (the exact
part-pair solver is :func:`impactnet.models.compound.oracle.part_pair_contacts`).

A committee member maps the pose of B's part in A's part frame (9 features, as
:func:`impactnet.models.learned.compound.groups.group_features` for a group of one part each)
to :data:`N_EXPERT_OUTPUTS` values: depth (m), normal (3, A's frame), point minus A's part
centre (3, m, A's frame) and the pressure integral (m^3). The answer is the members' mean; a
contact whose members spread more than the calibrated limits, or whose depth is not positive,
goes back to the exact part-pair solver.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.learned.compound.groups import PartGroup, group_features
from impactnet.models.learned.mlp import MLP
from impactnet.models.metrics import angle_deg

#: Outputs of a member: depth, normal (3), point offset (3), pressure.
N_EXPERT_OUTPUTS = 8


@dataclass(frozen=True)
class RegionCommittee:
    """The committee of one region, with the limits of its answers."""

    part_a: int  # A's part of the region
    part_b: int  # B's part of the region
    region: int  # the coarse region code of the contact (regions.coarse_regions)
    frame: PartGroup  # the two parts as a group of one part each: the members' input frame
    members: tuple[MLP, ...]  # K MLPs, 9 -> N_EXPERT_OUTPUTS
    sure_min: float  # the classifier's probability from which the committee answers
    normal_spread_max_deg: float  # members' normals further apart (deg): exact part solver
    depth_spread_max_m: float  # members' depths further apart (m): exact part solver
    contact_type_code: int  # the region's contact type (its most frequent in training)
    feature_a: int  # A's feature of that contact type
    feature_b: int  # B's feature

    def predict(self, position, rotation) -> tuple[np.ndarray, ...]:
        """(depth (k,), normal (k, 3), point (k, 3), pressure (k,), usable (k,) bool), A's
        frame, for B's poses in A's frame (``position`` (k, 3) m, ``rotation`` (k, 3, 3))."""
        x = group_features(self.frame, position, rotation).astype(np.float32)
        out = np.stack([m.forward(x) for m in self.members]).astype(np.float64)  # (K, k, 8)
        normals = out[:, :, 1:4] / np.maximum(np.linalg.norm(out[:, :, 1:4], axis=2,
                                                             keepdims=True), 1e-12)
        mean = out.mean(axis=0)
        normal = mean[:, 1:4] / np.maximum(np.linalg.norm(mean[:, 1:4], axis=1,
                                                          keepdims=True), 1e-12)
        spread_deg = np.max([angle_deg(n, normal) for n in normals], axis=0)
        depth_spread = out[:, :, 0].max(axis=0) - out[:, :, 0].min(axis=0)
        usable = ((spread_deg <= self.normal_spread_max_deg)
                  & (depth_spread <= self.depth_spread_max_m) & (mean[:, 0] > 0.0))
        point = mean[:, 4:7] + np.asarray(self.frame.centre_a)
        return mean[:, 0], normal, point, np.maximum(mean[:, 7], 0.0), usable
