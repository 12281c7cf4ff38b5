"""Labelled first-contact data for the learned predictors: `impactnet datagen`.

Stages (vectorised over the rows of a chunk; chunks run one after the other):

1. Seeds. A dataset seed and a pair's body names give the pair's ``SeedSequence``
   (:func:`pair_seed`: the SHA-256 of ``"a/b"`` is its spawn key), so adding, removing or
   reordering pairs of a scene leaves every other pair's rows unchanged. Chunk ``k`` of a pair
   draws from the child ``spawn_key + (k,)``.
2. Poses. A chunk of m rows is split between the orientation families in the shares of
   :class:`DatagenConfig` (exact counts, by rounding the cumulative shares), each family drawn by
   :func:`impactnet.models.geometry.poses.first_contact_poses`: relative orientation of the family,
   a random approach direction, B moved in exactly to first touch, then pushed in by a depth drawn
   from the depth range (or, for the separated share, pulled out by such a depth). The rows of the
   chunk are then shuffled, so that any prefix of the data mixes the families.
3. Labels. One :func:`impactnet.models.box.exact.box_box` call per chunk labels every row.

The same seed, sizes, n and config give the same arrays, byte for byte. ``chunk_size`` is part
of the config, because the chunk boundaries decide which random numbers go to which row.
"""
from __future__ import annotations

import hashlib
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from tqdm import tqdm

from impactnet.models.box.exact import box_box
from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.geometry.poses import ORIENTATIONS, first_contact_poses
from impactnet.models.scenes import BodyPair, Scene, load_scene
from impactnet.training.data import dataset_io

#: Version of the generator; bump it whenever the same seed and config would give other rows.
GENERATOR_VERSION = "1"
#: Allowed deviation (dimensionless) of the sum of the family shares from 1.
SHARE_SUM_TOL = 1e-9
#: Depth range used when neither the config nor the caller gives one (fractions of the pair's
#: shortest edge): the default scene's.
DEFAULT_DEPTH_FRACTION = (0.0, 0.01)

#: The six pose inputs, in `box_box` order.
INPUT_COLUMNS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")
#: Labels from the exact solver (fields of `impactnet.models.contacts.Contacts`).
LABEL_COLUMNS = ("colliding", "point", "normal", "depth", "contact_type_code", "feature_a",
                 "feature_b", "axis", "manifold_count")
#: Generation metadata: orientation family id (index into ORIENTATIONS) and push depth (m).
META_COLUMNS = ("family", "push_depth")
#: dtype and width (0 = one value per row) of every column of `generate_pairs`.
COLUMN_SPECS = {
    "size_a": ("<f8", 3), "position_a": ("<f8", 3), "quaternion_a": ("<f8", 4),
    "size_b": ("<f8", 3), "position_b": ("<f8", 3), "quaternion_b": ("<f8", 4),
    "colliding": ("|b1", 0), "point": ("<f8", 3), "normal": ("<f8", 3), "depth": ("<f8", 0),
    "contact_type_code": ("|i1", 0), "feature_a": ("|i1", 0), "feature_b": ("|i1", 0),
    "axis": ("|i1", 0), "manifold_count": ("|i1", 0), "family": ("|i1", 0),
    "push_depth": ("<f8", 0),
}


@dataclass(frozen=True)
class DatagenConfig:
    """How the rows of a pair are drawn; recorded in every manifest."""

    uniform_share: float = 0.55  # relative orientation uniform on SO(3) (Haar measure)
    near_parallel_faces_share: float = 0.15  # B's faces within a small tilt of A's faces
    near_parallel_edges_share: float = 0.15  # one edge of B within a small tilt of one of A's
    paper_share: float = 0.15  # the paper's protocol: Euler angles uniform in [-pi/2, pi/2]
    separated_share: float = 0.05  # rows pulled out by a depth of the range: "no contact"
    depth_fraction: tuple[float, float] | None = None  # overrides the scene's depth range
    chunk_size: int = 65536  # rows drawn and labelled per vectorised step; changes the data

    def __post_init__(self) -> None:
        shares = np.array(self.shares)
        if not (np.isfinite(shares).all() and (shares >= 0).all()):
            raise ValueError(f"family shares must be finite and >= 0, got {self.shares}")
        if abs(shares.sum() - 1.0) > SHARE_SUM_TOL:
            raise ValueError(f"family shares must sum to 1, got {shares.sum()!r}")
        if not 0.0 <= self.separated_share < 1.0:
            raise ValueError(f"separated_share must be in [0, 1), got {self.separated_share}")
        if self.depth_fraction is not None:
            _check_depth_fraction(self.depth_fraction)
        if isinstance(self.chunk_size, bool) or not isinstance(self.chunk_size, int) \
                or self.chunk_size < 1:
            raise ValueError(f"chunk_size must be an int >= 1, got {self.chunk_size!r}")

    @property
    def shares(self) -> tuple[float, float, float, float]:
        """Family shares in the order of :data:`impactnet.models.geometry.poses.ORIENTATIONS`."""
        return (self.uniform_share, self.near_parallel_faces_share,
                self.near_parallel_edges_share, self.paper_share)


class DatasetFiles(NamedTuple):
    """What :func:`generate_dataset` wrote."""

    npz: Path  # the arrays
    manifest_path: Path  # the JSON manifest
    manifest: dict  # its content


def _check_depth_fraction(depth_fraction) -> tuple[float, float]:
    """``(lo, hi)`` as floats; raises ValueError unless ``0 <= lo <= hi < 1``."""
    lo, hi = (float(v) for v in depth_fraction)
    if not 0.0 <= lo <= hi < 1.0:
        raise ValueError(f"depth_fraction must satisfy 0 <= lo <= hi < 1, got {depth_fraction}")
    return lo, hi


def family_counts(n: int, shares) -> np.ndarray:
    """Rows per family, int64, shape (len(shares),), summing to n exactly.

    Rounds the cumulative shares, so every count is within 1 of ``n * share``.
    """
    shares = np.asarray(shares, dtype=np.float64)
    bounds = np.rint(np.cumsum(shares / shares.sum()) * n).astype(np.int64)
    bounds[-1] = n
    return np.diff(bounds, prepend=0)


def pair_seed(seed: int, pair: BodyPair | tuple[str, str]) -> np.random.SeedSequence:
    """The SeedSequence of a pair: entropy ``seed``, spawn key from SHA-256 of ``"a/b"``."""
    a, b = (pair.a, pair.b) if isinstance(pair, BodyPair) else pair
    digest = hashlib.sha256(f"{a}/{b}".encode()).digest()
    key = tuple(int.from_bytes(digest[i:i + 4], "little") for i in range(0, 16, 4))
    return np.random.SeedSequence(seed, spawn_key=key)


def _empty_columns(n: int) -> dict[str, np.ndarray]:
    """Uninitialised columns for n rows, shaped and typed by :data:`COLUMN_SPECS`."""
    return {name: np.empty((n, width) if width else (n,), dtype=dtype)
            for name, (dtype, width) in COLUMN_SPECS.items()}


def _progress_bar(total: int, progress: bool | None, desc: str) -> tqdm:
    """A tqdm bar on stderr; ``progress=None`` shows it only when stderr is a terminal."""
    enabled = sys.stderr.isatty() if progress is None else progress
    return tqdm(total=total, desc=desc, unit="pair", unit_scale=True, disable=not enabled,
                file=sys.stderr, dynamic_ncols=True)


def generate_pairs(size_a, size_b, n: int, seed, config: DatagenConfig | None = None,
                   depth_fraction=None, progress: bool | None = None) -> dict[str, np.ndarray]:
    """Draw and label n first-contact configurations of one pair of boxes.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,)
        Full edge lengths of the two bodies, metres.
    n : int
        Number of rows.
    seed : int or numpy.random.SeedSequence
        Randomness; the same seed gives the same bytes.
    config : DatagenConfig, optional
        Family and separated shares, chunk size; default ``DatagenConfig()``.
    depth_fraction : (float, float), optional
        Push depth range as fractions of the pair's shortest edge (the scene's); the config's
        ``depth_fraction`` overrides it; default :data:`DEFAULT_DEPTH_FRACTION`.
    progress : bool or None
        Show a progress bar; None: only when stderr is a terminal.

    Returns
    -------
    dict of ndarray, n rows each (see :data:`COLUMN_SPECS`)
        Inputs ``size_a``, ``size_b``, ``position_a``, ``position_b`` (n, 3) metres,
        ``quaternion_a``, ``quaternion_b`` (n, 4) (w, x, y, z); labels from ``box_box``:
        ``colliding`` bool, ``point``, ``normal`` (n, 3), ``depth`` (n,) metres,
        ``contact_type_code``, ``feature_a``, ``feature_b``, ``axis``, ``manifold_count``
        int8; ``family`` int8 (index into ORIENTATIONS) and ``push_depth`` (n,) metres
        (> 0 pushed in, < 0 pulled out).
    """
    config = config or DatagenConfig()
    depth = resolve_depth_fraction(config, depth_fraction)
    n = _check_count(n, "n")
    out = _empty_columns(n)
    with _progress_bar(n, progress, "datagen") as bar:
        _fill_pairs(out, 0, size_a, size_b, n, seed, config, depth, bar)
    return out


def resolve_depth_fraction(config: DatagenConfig, scene_range=None) -> tuple[float, float]:
    """The depth range in force: the config's override, else the scene's, else the default."""
    chosen = config.depth_fraction or scene_range or DEFAULT_DEPTH_FRACTION
    return _check_depth_fraction(chosen)


def _fill_pairs(out: dict, start: int, size_a, size_b, n: int, seed, config: DatagenConfig,
               depth_fraction: tuple[float, float], bar: tqdm) -> None:
    """Write n labelled rows into ``out[...][start:start + n]``, chunk by chunk."""
    if not isinstance(seed, np.random.SeedSequence):
        seed = np.random.SeedSequence(_check_count(seed, "seed"))
    for k, lo in enumerate(range(0, n, config.chunk_size)):
        m = min(config.chunk_size, n - lo)
        child = np.random.SeedSequence(seed.entropy, spawn_key=seed.spawn_key + (k,))
        rows = _chunk(size_a, size_b, m, np.random.default_rng(child), config, depth_fraction)
        for name, value in rows.items():
            out[name][start + lo:start + lo + m] = value
        bar.update(m)


def _check_count(value, name: str, minimum: int = 0) -> int:
    """``value`` as an int >= minimum (seeds, row counts); ValueError otherwise."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")
    return int(value)


def _chunk(size_a, size_b, m: int, rng: np.random.Generator, config: DatagenConfig,
           depth_fraction: tuple[float, float]) -> dict[str, np.ndarray]:
    """m labelled rows: poses of every family in its share, shuffled, then labelled."""
    parts = []
    for family, count in enumerate(family_counts(m, config.shares)):
        if count == 0:
            continue
        poses = first_contact_poses(int(count), size_a, size_b, rng,
                                    depth_fraction=depth_fraction,
                                    separated_share=config.separated_share,
                                    orientation=ORIENTATIONS[family])
        poses["family"] = np.full(count, family, dtype=np.int8)
        parts.append(poses)
    order = rng.permutation(m)
    rows = {name: np.concatenate([p[name] for p in parts])[order]
            for name in INPUT_COLUMNS + META_COLUMNS}
    labels = box_box(*(rows[name] for name in INPUT_COLUMNS))
    rows.update({name: getattr(labels, name) for name in LABEL_COLUMNS})
    return rows


def generate_dataset(scene: Scene | str | Path, n_per_pair: int, seed: int,
                     config: DatagenConfig | None = None, out_dir="data",
                     progress: bool | None = None) -> DatasetFiles:
    """Generate, label and write the dataset of every pair of a scene.

    Writes ``<out_dir>/<scene.name>.npz`` (the columns of :func:`generate_pairs` plus
    ``pair_index`` int32, pairs in scene order, ``n_per_pair`` rows each) and
    ``<out_dir>/<scene.name>.json`` (the manifest, see :mod:`impactnet.training.data.dataset_io`).
    The same scene, n_per_pair, seed and config give the same bytes in both files.
    """
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    config = config or DatagenConfig()
    seed = _check_count(seed, "seed")
    n_per_pair = _check_count(n_per_pair, "n_per_pair", minimum=1)
    depth = resolve_depth_fraction(config, scene.depth_fraction)
    total = n_per_pair * len(scene.pairs)
    arrays = _empty_columns(total)
    with _progress_bar(total, progress, f"datagen {scene.name}") as bar:
        for k, ((size_a, size_b), pair) in enumerate(zip(scene.pair_sizes(), scene.pairs,
                                                         strict=True)):
            bar.set_postfix_str(pair.key)
            _fill_pairs(arrays, k * n_per_pair, size_a, size_b, n_per_pair,
                       pair_seed(seed, pair), config, depth, bar)
    arrays["pair_index"] = np.repeat(np.arange(len(scene.pairs), dtype=np.int32), n_per_pair)

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    npz_path = out_dir / f"{scene.name}.npz"
    digest = dataset_io.write_npz(npz_path, arrays)
    manifest = build_manifest(scene, n_per_pair, seed, config, depth, arrays)
    manifest["npz"] = {"file": npz_path.name, "bytes": npz_path.stat().st_size,
                       "sha256": digest}
    manifest_path = out_dir / f"{scene.name}.json"
    manifest_path.write_text(dataset_io.dumps_manifest(manifest), encoding="utf-8")
    return DatasetFiles(npz_path, manifest_path, manifest)


def build_manifest(scene: Scene, n_per_pair: int, seed: int, config: DatagenConfig,
                   depth_fraction: tuple[float, float], arrays: dict) -> dict:
    """The manifest of a dataset (without the ``npz`` entry): provenance and counts."""
    pairs = []
    for k, pair in enumerate(scene.pairs):
        block = {name: value[k * n_per_pair:(k + 1) * n_per_pair]
                 for name, value in arrays.items()}
        pairs.append({"index": k, "a": pair.a, "b": pair.b,
                      "size_a": list(scene.body(pair.a).size),
                      "size_b": list(scene.body(pair.b).size),
                      "shortest_edge": scene.smaller_shortest_edge(pair),
                      **dataset_io.summarize(block, ORIENTATIONS)})
    return {
        "format": dataset_io.FORMAT,
        "generator_version": GENERATOR_VERSION,
        "numpy_version": np.__version__,
        "seed": seed,
        "scene": {"name": scene.name, "hash": scene.hash(),
                  "depth_fraction": list(scene.depth_fraction)},
        "config": {k: list(v) if isinstance(v, tuple) else v
                   for k, v in asdict(config).items()},
        "depth_fraction": list(depth_fraction),
        "n_per_pair": n_per_pair,
        "rows": n_per_pair * len(scene.pairs),
        "families": list(ORIENTATIONS),
        "columns": dataset_io.column_specs(arrays),
        "pairs": pairs,
        "contact_types": list(CONTACT_TYPES),
        "totals": {k: v for k, v in dataset_io.summarize(arrays, ORIENTATIONS).items()
                   if k != "regions"},  # regions of different pairs are not comparable
    }
