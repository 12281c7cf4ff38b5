"""The seeded box sets of the golden answers, built with the project's own pose generators (not
a test module; the recorder's, it imports the training benches' generators).

* ``scene``: first contacts of every box pair of ``scenes/quay_crane.toml``
  (:func:`impactnet.training.bench.pose_sets.scene_poses`, interleaved over the pairs);
* ``stacking``: B resting on A, every family of
  :data:`impactnet.training.bench.contact_sets.STACKING_FAMILIES` at every tilt of
  :data:`~impactnet.training.bench.contact_sets.STACKING_TILTS` (0, then 1e-12 .. 1e-2 rad about
  random horizontal axes);
* ``figure2``: the paper's Figure 2 case (:func:`impactnet.training.bench.pose_sets.figure2_poses`);
* ``extremes``: the fuzz tests' poses (``tests/models/box/test_exact_invariants.fuzz_poses``:
  every size family, near-parallel faces and edges, 10 % separated, offset worlds), boxes at
  the domain's size limits (1 um, 1000 km) at first contact near the origin, 1e6 m and
  0.9e9 m away, exactly touching first contacts of every size family (no push), and boxes
  resting exactly on a face, an edge or a vertex, level or tilted by 1e-15 .. 1e-9 rad
  (``tests/models/box/sweeps.resting_poses``).

Each set is a dict of the six inputs (n, 3|4) plus ``family`` (n,) indexing ``families``.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.domain import POSITION_MAX_M, SIZE_MAX_M, SIZE_MIN_M
from impactnet.models.geometry.poses import SIZE_FAMILIES, first_contact_poses
from impactnet.models.scenes import load_scene
from tests.models.helpers import KEYS

#: Seeds of the sets (fixed: the golden files pin these very poses).
SEEDS = {"scene": 71, "stacking": 72, "figure2": 73, "extremes": 74}
#: Rows of the scene set, spread evenly over its 10 pairs.
SCENE_ROWS = 2000
#: Stacking rows per (family, tilt): 3 families x 12 tilts.
STACKING_PER_TILT = 30
#: Figure 2: tilts (10 deg down to 1e-6 rad) and placements per tilt.
FIGURE2_TILTS, FIGURE2_PER_TILT = 20, 10
#: Extremes: fuzz poses per (size family, orientation family), first contacts per (size pair,
#: world offset), exactly touching first contacts per size family.
FUZZ_PER_CASE, DOMAIN_PER_CASE, TOUCHING_PER_FAMILY = 10, 12, 10
#: Sizes at the domain's limits: tiny, huge, and a tiny-by-huge slab (metres).
TINY = (SIZE_MIN_M, 2 * SIZE_MIN_M, 1.5 * SIZE_MIN_M)
HUGE = (SIZE_MAX_M, 0.5 * SIZE_MAX_M, 0.8 * SIZE_MAX_M)
SLAB = (SIZE_MAX_M, SIZE_MAX_M, SIZE_MIN_M)
DOMAIN_PAIRS = {"tiny-tiny": (TINY, TINY), "tiny-huge": (TINY, HUGE), "huge-tiny": (HUGE, TINY),
                "huge-huge": (HUGE, HUGE), "slab-tiny": (SLAB, TINY)}
#: World offsets of the domain pairs (metres): the origin, 1e6 m, near the position limit.
DOMAIN_OFFSETS = {"origin": 0.0, "1e6": 1e6, "far": 0.9 * POSITION_MAX_M}
#: Resting tilts (radians) of the exact resting poses.
RESTING_TILTS = (0.0, 1e-15, 1e-12, 1e-9)


def _joined(chunks: list[tuple[str, dict]]) -> dict:
    """Chunks ``(family name, poses)`` as one set with ``family`` and ``families``."""
    names = list(dict.fromkeys(name for name, _ in chunks))
    out = {k: np.concatenate([np.asarray(c[k], np.float64) for _, c in chunks]) for k in KEYS}
    out["family"] = np.concatenate([np.full(len(c["size_a"]), names.index(name), np.int16)
                                    for name, c in chunks])
    out["families"] = np.array(names)
    return out


def scene_set() -> dict:
    """First contacts of the quay crane scene's box pairs."""
    from impactnet.training.bench.pose_sets import scene_poses

    scene = load_scene("quay_crane")
    poses = scene_poses(scene, SCENE_ROWS, SEEDS["scene"])
    out = dict(zip(KEYS, poses.args()))
    out["family"] = poses.pair.astype(np.int16)
    out["families"] = np.array([f"{a}/{b}" for a, b in poses.pair_names])
    return out


def stacking_set() -> dict:
    """Every stacking family at every tilt (level, then tilted about random axes)."""
    from impactnet.training.bench import contact_sets as cs

    rng = np.random.default_rng(SEEDS["stacking"])
    return _joined([(f"{family} tilt {tilt:g}",
                     cs.stacking_poses(STACKING_PER_TILT, size_a, size_b, tilt, rng))
                    for family, (size_a, size_b) in cs.STACKING_FAMILIES.items()
                    for tilt in cs.STACKING_TILTS])


def figure2_set() -> dict:
    """The paper's Figure 2 case: a tilted cube's vertex pressed into a cube's top face."""
    from impactnet.training.bench.pose_sets import figure2_poses

    poses = figure2_poses(load_scene("quay_crane"), FIGURE2_TILTS, FIGURE2_PER_TILT,
                          SEEDS["figure2"])
    out = dict(zip(KEYS, poses.args()))
    tilts = np.unique(poses.tilt)[::-1]
    out["family"] = np.searchsorted(-tilts, -poses.tilt).astype(np.int16)
    out["families"] = np.array([f"tilt {t:.3g}" for t in tilts])
    return out


def _resting_chunks() -> list[tuple[str, dict]]:
    """B resting exactly (depth 0) on a face, an edge or a vertex of A, level or tilted."""
    from tests.models.box import sweeps

    bases = {"face": sweeps.IDENTITY, "edge": sweeps.edge_down_base(),
             "vertex": sweeps.vertex_down_base()}
    chunks = []
    for name, base in bases.items():
        for stack, (size_a, size_b) in (("cube", (sweeps.CUBE, sweeps.CUBE)),
                                        ("c40", (sweeps.C40, sweeps.C40))):
            poses = sweeps.resting_poses(np.asarray(size_a), np.asarray(size_b), 0.0,
                                         yaw=np.array([0.0, np.pi / 4, 0.0, np.pi / 4] * 2),
                                         tilt=np.repeat(RESTING_TILTS, 2),
                                         axis=np.array([0.6, 0.8, 0.0]), base=base)
            chunks.append((f"resting on {name}, {stack}", poses))
    return chunks


def extremes_set() -> dict:
    """The extremes of the fuzz tests (module docstring)."""
    from tests.models.box.test_exact_invariants import fuzz_poses

    seed = SEEDS["extremes"]
    chunks = [("fuzz", fuzz_poses(seed, FUZZ_PER_CASE))]
    rng = np.random.default_rng(seed)
    for pair, (size_a, size_b) in DOMAIN_PAIRS.items():
        for where, offset in DOMAIN_OFFSETS.items():
            chunks.append((f"{pair} at {where}", first_contact_poses(
                DOMAIN_PER_CASE, size_a, size_b, rng, depth_fraction=(0.0, 0.01),
                separated_share=0.1, world_offset=offset * np.array([1.0, -1.0, 0.5]))))
    for family, (size_a, size_b) in sorted(SIZE_FAMILIES.items()):
        chunks.append((f"touching {family}", first_contact_poses(
            TOUCHING_PER_FAMILY, size_a, size_b, rng, depth_fraction=(0.0, 0.0))))
    return _joined(chunks + _resting_chunks())


BUILDERS = {"scene": scene_set, "stacking": stacking_set, "figure2": figure2_set,
            "extremes": extremes_set}
