"""Reading and writing the golden files (compact ``.npz`` under ``tests/data/golden/``).

A box file holds, per row: the six solver inputs (float64), ``family`` (int16) indexing
``families``, every output field of :class:`impactnet.models.contacts.Contacts` (float64 where
exactness matters; the manifold ragged: ``manifold_points`` (m, 3) and ``manifold_depths``
(m,) of the ``manifold_count`` valid slots, row after row), and the comparison rule's data
(:mod:`tests.golden.rule`): ``margins`` (n, K) float32 (columns ``margin_names``), ``reach``,
``tied`` (bitmask over the 15 axes), ``tie_width`` (x pair scale) and ``causes``.

A compound file holds per pose the bodies' poses and the summary fields, the part contacts
with the prefix ``part_`` (the same fields, plus ``part_pose``, ``part_a``, ``part_b`` and
``offsets`` (n + 1,)), their rule data, the borderline part pairs absent from the answer
(``absent_*``) and the bodies' fingerprints (:mod:`tests.golden.compound_store`).

Not a test module; imports the models only.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from impactnet.models.contacts import MAX_MANIFOLD_POINTS

#: Where the golden files live; ``IMPACTNET_GOLDEN_DIR`` points the tests and the recorder at
#: another copy (a temporary one, to see the tests fail on a deliberately changed value).
GOLDEN_DIR = Path(os.environ.get("IMPACTNET_GOLDEN_DIR",
                                 Path(__file__).resolve().parents[1] / "data" / "golden"))
#: Format version, written into every file and checked on loading.
FORMAT_VERSION = 1
#: Output fields stored as they are (float64 / integer arrays of n rows).
PLAIN_FIELDS = ("colliding", "point", "normal", "depth", "contact_type_code", "feature_a",
                "feature_b", "axis", "manifold_count", "pressure")
#: Rule data of a row and its stored dtype.
RULE_FIELDS = {"margins": np.float32, "reach": np.float32, "tied": np.uint16,
               "tie_width": np.float32, "causes": np.uint8}


def pack_contacts(contacts, prefix: str = "") -> dict[str, np.ndarray]:
    """The fields of a ``Contacts`` as arrays to store, the manifold ragged."""
    arrays = contacts.arrays()
    out = {prefix + name: np.asarray(arrays[name]) for name in PLAIN_FIELDS}
    count = np.asarray(arrays["manifold_count"], np.int64)
    valid = np.arange(MAX_MANIFOLD_POINTS)[None, :] < count[:, None]
    out[prefix + "manifold_points"] = arrays["manifold_points"][valid]
    out[prefix + "manifold_depths"] = arrays["manifold_depths"][valid]
    return out


def unpack_contacts(data: dict, prefix: str = "") -> dict[str, np.ndarray]:
    """The stored fields back as arrays of n rows, the manifold as (n, 8, 3) and (n, 8)."""
    out = {name: data[prefix + name] for name in PLAIN_FIELDS}
    count = out["manifold_count"].astype(np.int64)
    valid = np.arange(MAX_MANIFOLD_POINTS)[None, :] < count[:, None]
    points = np.zeros((len(count), MAX_MANIFOLD_POINTS, 3))
    depths = np.zeros((len(count), MAX_MANIFOLD_POINTS))
    points[valid], depths[valid] = data[prefix + "manifold_points"], data[prefix +
                                                                          "manifold_depths"]
    out["manifold_points"], out["manifold_depths"] = points, depths
    return out


def pack_rule(found, prefix: str = "") -> dict[str, np.ndarray]:
    """The rule data of :class:`tests.golden.box_margins.BoxMargins`-like ``found``."""
    return {prefix + name: np.asarray(getattr(found, name)).astype(dtype)
            for name, dtype in RULE_FIELDS.items()}


def save(name: str, arrays: dict[str, np.ndarray], folder: Path = GOLDEN_DIR) -> Path:
    """Write ``arrays`` (plus the format version) as ``<folder>/<name>.npz``, compressed."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.npz"
    np.savez_compressed(path, format_version=np.array(FORMAT_VERSION), **arrays)
    return path


def load(name: str, folder: Path = GOLDEN_DIR) -> dict[str, np.ndarray]:
    """The arrays of ``<folder>/<name>.npz`` (no pickles), format version checked."""
    with np.load(folder / f"{name}.npz", allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    version = int(arrays.pop("format_version"))
    if version != FORMAT_VERSION:
        raise ValueError(f"{name}.npz: golden format {version}, expected {FORMAT_VERSION}")
    return arrays
