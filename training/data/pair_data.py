"""The data of one body pair for the learned predictors: rows, splits, region classes.

Stages of :func:`make_pair_data`:

1. Rows: :func:`impactnet.training.data.datagen.generate_pairs` draws and labels ``rows``
first-contact
   configurations with the pair's seed (:func:`impactnet.training.data.datagen.pair_seed`) and the
   scene's depth range.
2. Learning arrays: :func:`impactnet.models.learned.canonical.learning_arrays` (the inference side's
code, so
   both sides agree) gives ``pose-v1`` features, ``contact-v1`` targets and canonical region keys;
   :func:`impactnet.models.learned.region_label.unclipped_points` the unclipped point, from which
   the experts learn the residual (:meth:`PairData.expert_targets`).
3. Splits: a permutation seeded by the pair's seed splits the rows into train / validation /
   test by the configured shares. Validation drives early stopping and the ``auto``
   calibration; test is only measured.
4. Region classes (:func:`region_classes`): ``"none"`` first, then every face-axis region with
   at least ``min_region_rows`` training rows, most frequent first. Rarer regions get no
   class and no committee: their rows are labelled -1, and at inference the exact solver
   answers them (see :mod:`impactnet.training.fit.committee`). Edge-edge rows and parallel aligned
   face rows (labelled -2) need no committee: the region labeller gives their point exactly
   (:func:`impactnet.models.learned.region_label.face_features`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.learned import canonical as cn
from impactnet.models.learned.region_label import unclipped_points
from impactnet.training.data.datagen import DatagenConfig, generate_pairs

#: The six input columns of a dataset, in box_box's order.
INPUT_KEYS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")

#: Label of rows whose region has no class (too rare for a committee; answered exactly).
UNSURE_LABEL = -1
#: Label of the rows whose point the region labeller gives exactly (edge-edge: the closest
#: points of the two edges; face contacts with nothing to clip), so they need no committee.
EXACT_POINT_LABEL = -2
#: Region keys of edge-edge contacts start with this.
_EDGE_EDGE_PREFIX = "edge-edge:"
#: Spawn-key suffix of the split's random stream under the pair's seed (datagen's chunks use
#: suffixes 0, 1, ...; this one is far beyond any chunk count).
SPLIT_STREAM = 1_000_001


@dataclass(frozen=True)
class PairDataConfig:
    """How much data a pair gets and how it is split."""

    rows: int = 300_000  # labelled rows drawn per pair (all splits)
    val_share: float = 0.15  # share of rows for validation (early stopping, calibration)
    test_share: float = 0.15  # share of rows held out for the test figures
    min_region_rows: int = 600  # training rows a region needs for a class and a committee

    def __post_init__(self) -> None:
        if not (0 < self.val_share < 1 and 0 < self.test_share < 1
                and self.val_share + self.test_share < 1):
            raise ValueError("val_share and test_share must be in (0, 1) and sum below 1")
        if self.rows < 10 or self.min_region_rows < 1:
            raise ValueError("rows must be >= 10 and min_region_rows >= 1")


@dataclass
class PairData:
    """Learning arrays of one pair, split, with its region classes."""

    features: np.ndarray  # (n, 12) float32, pose-v1
    targets: np.ndarray  # (n, 7) float32, contact-v1 (meaningless on "none" rows)
    keys: np.ndarray  # (n,) str, canonical region keys
    labels: np.ndarray  # (n,) int64, class index into regions, UNSURE_LABEL for rare regions,
    # EXACT_POINT_LABEL for edge-edge rows
    regions: list[str]  # the regions with a committee, "none" first
    split: dict[str, np.ndarray]  # "train", "val", "test" -> row indices (int64)
    scale: float  # pair scale L = max(h_A) + max(h_B), metres
    edge: float  # shortest edge e of the pair, metres
    depth_fraction: tuple[float, float]  # trained depth range, fractions of e
    unclipped: np.ndarray  # (n, 3) float32, the region labeller's unclipped point, canonical
    # A frame / L (impactnet.models.learned.region_label; meaningless on "none" rows)

    def expert_targets(self) -> np.ndarray:
        """The experts' targets (n, 7) float32: ``contact-v1`` with the point replaced by its
        residual from the unclipped point (what the experts learn)."""
        targets = self.targets.copy()
        targets[:, :3] -= self.unclipped
        return targets

    def rows(self, split: str, colliding: bool = False) -> np.ndarray:
        """Row indices of a split, only the colliding ones (key != "none") if asked."""
        index = self.split[split]
        return index[self.keys[index] != cn.NONE_KEY] if colliding else index

    def region_rows(self, split: str) -> list[np.ndarray]:
        """Row indices of a split per region class 1.. (the committees' regions)."""
        index = self.split[split]
        labels = self.labels[index]
        return [index[labels == r] for r in range(1, len(self.regions))]


def stream(seed: np.random.SeedSequence, suffix: int) -> np.random.SeedSequence:
    """The child of ``seed`` with spawn key ``seed.spawn_key + (suffix,)`` (no state change)."""
    return np.random.SeedSequence(seed.entropy, spawn_key=tuple(seed.spawn_key) + (suffix,))


def split_rows(n: int, config: PairDataConfig, seed: np.random.SeedSequence) -> dict:
    """Train / val / test row indices (int64, sorted) from a seeded permutation of n rows."""
    order = np.random.default_rng(seed).permutation(n)
    n_val, n_test = int(round(n * config.val_share)), int(round(n * config.test_share))
    parts = {"val": order[:n_val], "test": order[n_val:n_val + n_test],
             "train": order[n_val + n_test:]}
    return {name: np.sort(part).astype(np.int64) for name, part in parts.items()}


def region_classes(keys: np.ndarray, train: np.ndarray, min_rows: int,
                   exact_point: np.ndarray | None = None):
    """Classes and labels of every row (see the module docstring, stage 4).

    Returns
    -------
    regions : list of str
        ``"none"`` then the regions with >= ``min_rows`` training rows, by count, then key.
    labels : ndarray of int64, shape (n,)
        Class index of every row, :data:`UNSURE_LABEL` for rows of rarer regions,
        :data:`EXACT_POINT_LABEL` for edge-edge rows and the rows ``exact_point`` flags (n,)
        (no committee: the region labeller's point is exact; they do not count for
        ``min_rows``).
    """
    exact_point = np.zeros(len(keys), bool) if exact_point is None else exact_point
    names, counts = np.unique(keys[train][~exact_point[train]], return_counts=True)
    kept = [(-c, str(k)) for k, c in zip(names, counts) if c >= min_rows and k != cn.NONE_KEY
            and not str(k).startswith(_EDGE_EDGE_PREFIX)]
    regions = [cn.NONE_KEY] + [k for _, k in sorted(kept)]
    lookup = {k: i for i, k in enumerate(regions)}
    unique, inverse = np.unique(keys, return_inverse=True)
    table = np.array([EXACT_POINT_LABEL if str(k).startswith(_EDGE_EDGE_PREFIX)
                      else lookup.get(str(k), UNSURE_LABEL) for k in unique], dtype=np.int64)
    labels = table[inverse.reshape(-1)]
    labels[exact_point] = EXACT_POINT_LABEL
    return regions, labels


def make_pair_data(size_a, size_b, seed: np.random.SeedSequence,
                   depth_fraction: tuple[float, float], config: PairDataConfig,
                   datagen: DatagenConfig | None = None) -> PairData:
    """Rows, learning arrays, splits and classes of one pair (module docstring).

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,)
        Full edge lengths of A and B, metres.
    seed : numpy.random.SeedSequence
        The pair's seed (``impactnet.training.data.datagen.pair_seed(seed, pair)``); the split draws
        from its stream :data:`SPLIT_STREAM`.
    depth_fraction : (float, float)
        The scene's depth range, fractions of the shortest edge.
    config, datagen : PairDataConfig, DatagenConfig
    """
    rows = generate_pairs(size_a, size_b, config.rows, seed, datagen,
                          depth_fraction=depth_fraction, progress=False)
    unclipped, exact_point = unclipped_points(*(rows[k] for k in INPUT_KEYS))
    exact_point &= rows["colliding"]
    arrays = cn.learning_arrays(rows, (unclipped,))
    baseline = arrays.points[0]
    split = split_rows(config.rows, config, stream(seed, SPLIT_STREAM))
    regions, labels = region_classes(arrays.keys, split["train"], config.min_region_rows,
                                     exact_point)
    half_a, half_b = np.asarray(size_a, float)[None] / 2, np.asarray(size_b, float)[None] / 2
    scale, edge = cn.pair_lengths(half_a, half_b)
    return PairData(arrays.features, arrays.targets, arrays.keys, labels, regions, split,
                    float(scale[0]), float(edge[0]), tuple(float(v) for v in depth_fraction),
                    baseline)
