"""The seeded compound sets of the golden answers, built with the project's own generators (not
a test module; the recorder's, it imports the training data's pose families).

Bodies from :mod:`impactnet.models.compound` (A at the origin, unrotated; B placed):

* ``castings``: a 40 ft container on a 40 ft container, solid corner castings (detail 1);
* ``apertures``: the same at detail 2 (the top castings' apertures as ring pieces);
* ``twistlocks_8`` .. ``twistlocks_256``: a 40 ft spreader with twistlock heads of 8, 32, 128 and
  256 sides landing on a detail-2 40 ft container;
* ``cell_guide``: a 40 ft container (detail 1) sliding along a cell guide.

Poses: exact aligned poses (:data:`ALIGNED_PUSHES_M`), then the pair's first-contact families
(:func:`impactnet.training.data.compound_data.pair_families`,
:func:`impactnet.training.data.compound_poses.family_poses`: stacking and near stacking,
twistlock entry, guide sliding), each in three depth bands (:data:`DEPTH_BANDS`): pushed 0-2 mm
past the first contact, pulled back (separated) and pushed deep.
"""
from __future__ import annotations

import hashlib

import numpy as np

from impactnet.models.compound import cell_guide, container, spreader

#: Pushes past the first contact (metres) and each band's share of a set's poses.
DEPTH_BANDS = {"contact": ((0.0, 2e-3), 0.7), "separated": ((-3e-3, -1e-5), 0.15),
               "deep": ((5e-3, 3e-2), 0.15)}
#: Exact poses added to every family: B at the family's nominal pose (level, aligned, just
#: touching), offset across the approach by 0 or (1 mm, 0.5 mm) and pushed along it by these
#: distances (metres): coplanar faces, aligned edges, equal contacts at every corner.
ALIGNED_PUSHES_M = (-1e-3, 0.0, 1e-4, 2e-3, 2e-2)
ALIGNED_OFFSETS_M = ((0.0, 0.0, 0.0), (1e-3, 5e-4, 0.0))
#: name -> (body A, body B, poses, seed); bodies as (generator, keyword arguments).
SETS = {
    "castings": ((container, {"kind": "40ft", "detail": 1}),
                 (container, {"kind": "40ft", "detail": 1}), 300, 81),
    "apertures": ((container, {"kind": "40ft", "detail": 2}),
                  (container, {"kind": "40ft", "detail": 2}), 200, 82),
    "twistlocks_8": ((container, {"kind": "40ft", "detail": 2}),
                     (spreader, {"kind": "40ft", "sides": 8}), 200, 83),
    "twistlocks_32": ((container, {"kind": "40ft", "detail": 2}),
                      (spreader, {"kind": "40ft", "sides": 32}), 200, 84),
    "twistlocks_128": ((container, {"kind": "40ft", "detail": 2}),
                       (spreader, {"kind": "40ft", "sides": 128}), 150, 85),
    "twistlocks_256": ((container, {"kind": "40ft", "detail": 2}),
                       (spreader, {"kind": "40ft", "sides": 256}), 120, 86),
    "cell_guide": ((cell_guide, {}), (container, {"kind": "40ft", "detail": 1}), 300, 87),
}


def body_label(body) -> str:
    """``"container(kind='40ft', detail=2)"`` for a (generator, kwargs) pair."""
    make, kwargs = body
    return f"{make.__name__}({', '.join(f'{k}={v!r}' for k, v in kwargs.items())})"


def bodies(name: str):
    """The two bodies' parts of set ``name``."""
    (make_a, kwargs_a), (make_b, kwargs_b) = SETS[name][:2]
    return make_a(**kwargs_a), make_b(**kwargs_b)


def fingerprint(parts) -> str:
    """SHA-256 of the parts' repr (names, sizes, centres, points): the golden answers hold
    only for the very bodies they were recorded with."""
    return hashlib.sha256(repr(tuple(parts)).encode()).hexdigest()


def compound_set(name: str) -> dict:
    """The poses of set ``name``: ``position_b`` (n, 3), ``quaternion_b`` (n, 4), A's at the
    origin, ``family`` (n,) indexing ``families``."""
    from impactnet.training.data.compound_data import pair_families
    from impactnet.training.data.compound_poses import family_poses

    parts_a, parts_b = bodies(name)
    total, seed = SETS[name][2:]
    rng = np.random.default_rng(seed)
    families = pair_families(parts_a, parts_b)
    chunks, names = [], []
    for family, (nominal, approach) in families.items():
        offset = np.asarray(ALIGNED_OFFSETS_M)
        offset = offset - (offset @ approach)[:, None] * approach  # across the approach only
        position = (nominal + offset[:, None, :] + np.multiply.outer(ALIGNED_PUSHES_M, approach)
                    [None]).reshape(-1, 3)
        chunks.append((position, np.tile([1.0, 0.0, 0.0, 0.0], (len(position), 1)),
                       np.full(len(position), len(names), np.int16)))
        names.append(f"{family} aligned")
    for band, (depth_range, share) in DEPTH_BANDS.items():
        for family, (nominal, approach) in families.items():
            n = max(1, int(round(total * share / len(families))))
            position, quaternion, _ = family_poses(family, parts_a, parts_b, nominal, approach,
                                                   depth_range, n, rng)
            chunks.append((position, quaternion, np.full(len(position), len(names), np.int16)))
            names.append(f"{family} {band}")
    n = sum(len(c[0]) for c in chunks)
    return {"position_a": np.zeros((n, 3)), "quaternion_a": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
            "position_b": np.concatenate([c[0] for c in chunks]),
            "quaternion_b": np.concatenate([c[1] for c in chunks]),
            "family": np.concatenate([c[2] for c in chunks]), "families": np.array(names)}
