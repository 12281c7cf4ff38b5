"""The pose `impactnet show` draws: one first-contact pose of the pair's family, from a seed."""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.parts import BoxPart


def body_parts(scene, name: str) -> tuple:
    """A scene body's parts: its own, or a box body as one box part."""
    body = scene.body(name)
    return body.parts if body.is_compound else (BoxPart(name, tuple(body.size)),)


def contact_pose(parts_a, parts_b, seed: int, depth_m: float):
    """B's position (3,) and quaternion (4,) against A at the origin: the first pose of the
    pair's first family (:func:`impactnet.training.data.compound_data.pair_families`) that
    touches, pushed ``depth_m`` past its first contact; None if no seed-drawn pose touches."""
    from impactnet.training.data.compound_data import pair_families
    from impactnet.training.data.compound_poses import family_poses

    rng = np.random.default_rng(seed)
    family, (nominal, approach) = next(iter(pair_families(parts_a, parts_b).items()))
    position, quaternion, _ = family_poses(family, parts_a, parts_b, nominal, approach,
                                           (depth_m, depth_m), 8, rng)
    if not len(position):
        return None
    return position[0], quaternion[0]
