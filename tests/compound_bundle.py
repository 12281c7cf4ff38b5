"""A small bundle of ``quay_crane_detail`` with learned compound models, for the training,
bundle and service tests: the cell guide pair (cheap to label) trained in the quick
configuration with the classifiers always trained. ``learned=True`` records the pair as
learned whatever its measurement said (the tests exercise serving, not the decision)."""
from __future__ import annotations

import functools

import numpy as np

from impactnet.models.scenes import load_scene

GUIDE_PAIR = "cell_guide/container40"


@functools.lru_cache(maxsize=2)
def guide_rows(n: int = 400, seed: int = 0) -> dict:
    """Labelled first-contact rows of the cell guide pair (A at the origin)."""
    from impactnet.training.data.compound_data import compound_rows

    scene = load_scene("quay_crane_detail")
    pair = scene.pairs[[p.key for p in scene.pairs].index(GUIDE_PAIR)]
    edge = scene.smaller_shortest_edge(pair)
    return compound_rows(scene.body(pair.a).parts, scene.body(pair.b).parts, n,
                         tuple(edge * f for f in scene.depth_fraction),
                         np.random.default_rng(seed))


@functools.lru_cache(maxsize=1)
def guide_entry() -> tuple[dict, dict, dict]:
    """(entry, tensors, specs) of the guide pair trained quickly, classifiers kept."""
    import dataclasses

    from impactnet.training.compound.pair import train_compound_pair
    from impactnet.training.compound.settings import compound_config

    scene = load_scene("quay_crane_detail")
    pair = scene.pairs[[p.key for p in scene.pairs].index(GUIDE_PAIR)]
    config = dataclasses.replace(compound_config(0, quick=True), keep_models=True)
    return train_compound_pair(scene, pair, guide_rows(), config, log=lambda m: None)


def guide_manifest(learned: bool = True) -> tuple[dict, dict]:
    """(manifest, tensors) of a bundle holding only the guide pair."""
    import copy

    entry, tensors, specs = guide_entry()
    entry = copy.deepcopy(entry)
    if learned:
        entry["decision"]["serve"] = "learned"
    scene = load_scene("quay_crane_detail")
    return ({"version": "guide-test", "scene": {"name": scene.name, "hash": scene.hash()},
             "mlps": dict(specs), "pairs": {}, "compound_pairs": {GUIDE_PAIR: entry}},
            dict(tensors))


def guide_scene(folder, name: str = "guide_only"):
    """``quay_crane_detail`` with its cell guide pair only, as a TOML file in ``folder`` (the
    cheapest compound pair to label: for tests that label a scene's every pair)."""
    from pathlib import Path

    from impactnet.models.scenes import scene_path

    head, *pairs = scene_path("quay_crane_detail").read_text().split("[[pairs]]")
    keep = [p for p in pairs if 'a = "cell_guide"' in p]
    assert len(keep) == 1
    head = head.replace('name = "quay_crane_detail"', f'name = "{name}"')
    path = Path(folder) / f"{name}.toml"
    path.write_text(head + "[[pairs]]" + keep[0])
    return path
