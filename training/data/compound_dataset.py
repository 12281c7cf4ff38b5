"""`impactnet datagen` for the compound pairs of a scene: ``<out>/<scene>.compound.npz`` and
``<out>/<scene>.compound.json``.

The npz holds, for pair k of the scene's compound pairs (scene order), the columns of
:func:`impactnet.training.data.compound_data.compound_rows` named ``pair{k}.<column>``; the
JSON manifest names the pairs, their rows and part contacts, and the scene's hash. The same
scene, rows and seed give the same arrays.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from impactnet.models.scenes import Scene
from impactnet.training.data.compound_data import compound_rows
from impactnet.training.data.compound_poses import FAMILIES
from impactnet.training.data.datagen import pair_seed


def compound_pairs(scene: Scene) -> list:
    """The scene's pairs with a compound body, in scene order."""
    return [p for p in scene.pairs if scene.body(p.a).is_compound or scene.body(p.b).is_compound]


def is_compound_scene(scene: Scene) -> bool:
    """Whether every pair of ``scene`` has a compound body: the scene goes to the compound
    learned path (``impactnet train`` / ``evaluate`` / ``sweep``); a scene mixing both kinds is
    refused by the box commands."""
    return bool(scene.pairs) and len(compound_pairs(scene)) == len(scene.pairs)


def _as_parts(body):
    """A body's parts: its own, or a plain box as one box part."""
    from impactnet.models.compound.parts import BoxPart

    return body.parts if body.is_compound else (BoxPart("box", tuple(body.size)),)


def generate_compound_dataset(scene: Scene, n_per_pair: int, seed: int, out_dir) -> dict:
    """Label about ``n_per_pair`` first-contact poses of every compound pair; returns the
    manifest (also written next to the npz)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    arrays, pairs = {}, []
    for k, pair in enumerate(compound_pairs(scene)):
        rng = np.random.default_rng(pair_seed(seed, pair))
        edge = scene.smaller_shortest_edge(pair)
        depths = tuple(edge * f for f in scene.depth_fraction)
        rows = compound_rows(_as_parts(scene.body(pair.a)), _as_parts(scene.body(pair.b)),
                             n_per_pair, depths, rng)
        arrays |= {f"pair{k}.{name}": value for name, value in rows.items()}
        families = [FAMILIES[f] for f in np.unique(rows["family"])]
        pairs.append({"index": k, "a": pair.a, "b": pair.b, "rows": len(rows["push"]),
                      "families": families, "depth_range_m": list(depths),
                      "part_contacts": int(rows["contact_offsets"][-1]),
                      "colliding": int(rows["colliding"].sum())})
    npz_path = out_dir / f"{scene.name}.compound.npz"
    np.savez(npz_path, **arrays)
    manifest = {"scene": {"name": scene.name, "hash": scene.hash()}, "seed": seed,
                "n_per_pair": n_per_pair, "pairs": pairs, "npz": npz_path.name}
    (out_dir / f"{scene.name}.compound.json").write_text(json.dumps(manifest, indent=2) + "\n",
                                                         encoding="utf-8")
    return manifest
