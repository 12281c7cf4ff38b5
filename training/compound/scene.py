"""`impactnet train` for a scene of compound pairs: every pair trained, measured and decided
(:mod:`impactnet.training.compound.pair`), written as a new version of the bundle store.

The labelled rows come from the compound dataset of ``impactnet datagen``
(``<data>/<scene>.compound.npz``, :mod:`impactnet.training.data.compound_dataset`) when one for
this scene (same hash) and at least as many rows per pair is there, else they are labelled here
(and written there, for the next run). The bundle's ``compound_pairs`` hold each pair's
decision with its figures; an exact-only pair keeps its figures and no model. The version is
written to ``<out>/versions/<version>`` and ``current`` moves to it once it reads back
(:func:`impactnet.models.bundle.format.read_bundle`).
"""
from __future__ import annotations

import hashlib
import json
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import safetensors.numpy
import torch

from impactnet.models.bundle.store import VERSIONS, prune, set_current
from impactnet.models.learned.bundle_loader import read_bundle, write_bundle
from impactnet.models.scenes import Scene
from impactnet.training.compound.pair import CompoundTrainConfig, train_compound_pair
from impactnet.training.compound.rows import pair_columns
from impactnet.training.data.compound_dataset import compound_pairs, generate_compound_dataset
from impactnet.training.data.pair_cache import plain

#: Labelled first-contact rows per pair by default (the spreader's take ~30 ms each to label).
ROWS_PER_PAIR = 16_000
#: Versions kept in the store after a run (the current one always stays).
KEEP_VERSIONS = 5


def labelled_data(scene: Scene, rows: int, seed: int, data_dir, log=print):
    """The scene's compound dataset (npz) with at least ``rows`` rows per pair: read from
    ``data_dir`` where it matches the scene, else labelled and written there."""
    data_dir = Path(data_dir)
    manifest_path = data_dir / f"{scene.name}.compound.json"
    if manifest_path.is_file():
        manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        if (manifest["scene"]["hash"] == scene.hash() and manifest["seed"] == seed
                and manifest["n_per_pair"] >= rows):
            log(f"labelled rows from {data_dir} ({manifest['n_per_pair']} per pair)")
            return np.load(data_dir / manifest["npz"])
    log(f"labelling {rows} first-contact rows per pair into {data_dir}")
    generate_compound_dataset(scene, rows, seed, data_dir)
    return np.load(data_dir / f"{scene.name}.compound.npz")


def train_compound_scene(scene: Scene, out, config: CompoundTrainConfig, rows: int,
                         data_dir, log=print) -> tuple[Path, dict]:
    """Train, measure and decide every compound pair of ``scene``; publish the bundle as a new
    version of the store ``out``. Returns (version folder, manifest)."""
    start = time.perf_counter()
    npz = labelled_data(scene, rows, config.seed, data_dir, log)
    entries, tensors, specs = {}, {}, {}
    for k, pair in enumerate(compound_pairs(scene)):
        columns = pair_columns(npz, k)
        entry, t, s = train_compound_pair(scene, pair, columns, config, log)
        entries[pair.key], tensors, specs = entry, tensors | t, specs | s
    manifest = _manifest(scene, entries, tensors, specs, config, rows, out,
                         time.perf_counter() - start)
    store = Path(out)
    path = write_bundle(store / VERSIONS / manifest["version"], manifest, tensors)
    read_bundle(path)
    set_current(store, manifest["version"])
    prune(store, KEEP_VERSIONS)
    return path, read_bundle(path).manifest


def _manifest(scene: Scene, entries: dict, tensors: dict, specs: dict,
              config: CompoundTrainConfig, rows: int, out, seconds: float) -> dict:
    from impactnet import __version__

    arrays = {k: np.ascontiguousarray(v, np.float32) for k, v in tensors.items()}
    digest = hashlib.sha256(safetensors.numpy.save(arrays)).hexdigest()
    now = datetime.now(UTC)
    return {
        "version": f"{scene.name}-{now:%Y%m%dT%H%M%SZ}-{digest[:8]}",
        "created_utc": now.isoformat(timespec="seconds"),
        "impactnet_version": __version__,
        "scene": {"name": scene.name, "hash": scene.hash()},
        "rebuild_command": (f"impactnet train --scene {scene.name} --out "
                            f"{Path(out).as_posix()} --seed {config.seed} --rows {rows}"),
        "seeds": {"data": config.seed, "torch": config.seed},
        "training": {"config": plain(config) | {"rows_per_pair": rows},
                     "torch_version": torch.__version__, "seconds": round(seconds, 1)},
        "mlps": specs, "pairs": {}, "compound_pairs": entries,
    }
