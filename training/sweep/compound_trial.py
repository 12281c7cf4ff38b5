"""`impactnet sweep` on compound pairs (issue #21, step 5): a trial draws the learned path's
settings, trains the trial's compound pairs
(:func:`impactnet.training.compound.pair.train_compound_pair`) on the scene's labelled rows and
returns the same three objectives as on box pairs, all minimised:

1. ``fallback``: share of the held-out rows that ``auto`` sends to the oracle (pooled over the
   trial's pairs);
2. ``point_p99``: the worst p99 error of ``auto`` on those rows in units of the scene's
   tolerance (the largest of depth and point over their tolerances: 1 meets both);
3. ``auto_us``: measured ``auto`` µs per pose at the timing batch (summed over the pairs).

A trial *meets* the tolerance (user attribute ``meets``, read by the report) when the p99
depth, normal and point errors are within tolerance and no more than 0.01 % of the rows miss a
contact. The labelled rows are read from (or written to) ``<workdir>/data``, once per worker.
"""
from __future__ import annotations

import dataclasses
import os
import socket
import time
from dataclasses import dataclass
from pathlib import Path

from impactnet.training.compound.measure import MISSED_MAX, TimingConfig
from impactnet.training.compound.pair import CompoundTrainConfig, train_compound_pair
from impactnet.training.compound.rows import pair_columns
from impactnet.training.compound.scene import labelled_data
from impactnet.training.compound.settings import compound_config
from impactnet.training.data.compound_dataset import compound_pairs


@dataclass(frozen=True)
class CompoundSpace:
    """Ranges of the searched settings of a compound pair (inclusive)."""

    width: tuple[int, int] = (32, 256)  # classifier hidden width (log scale)
    depth: tuple[int, int] = (1, 3)  # classifier hidden layers
    members: tuple[int, int] = (1, 5)  # committee size K
    expert_width: tuple[int, int] = (16, 128)  # committee members' hidden width (log scale)

    def to_dict(self) -> dict:
        """JSON-ready ranges (stored with the study)."""
        return {f.name: list(getattr(self, f.name)) for f in dataclasses.fields(self)}


def quick_compound_space() -> CompoundSpace:
    """Small networks: seconds per trial (tests, smoke runs)."""
    return CompoundSpace(width=(8, 32), depth=(1, 2), members=(1, 2), expert_width=(8, 16))


def suggest_compound(trial, space: CompoundSpace,
                     base: CompoundTrainConfig) -> CompoundTrainConfig:
    """``base`` with the searched settings drawn by ``trial``."""
    width = trial.suggest_int("width", *space.width, log=True)
    depth = trial.suggest_int("depth", *space.depth)
    members = trial.suggest_int("members", *space.members)
    expert_width = trial.suggest_int("expert_width", *space.expert_width, log=True)
    return dataclasses.replace(
        base, classifier=dataclasses.replace(base.classifier, hidden=(width,) * depth),
        experts=dataclasses.replace(base.experts, members=members,
                                    hidden=(expert_width, expert_width)))


class CompoundObjective:
    """A trial on compound pairs (module docstring)."""

    def __init__(self, config, scene) -> None:
        self.config, self.scene = config, scene
        pairs = compound_pairs(scene)
        keys = config.pair_keys or (pairs[0].key,)
        self.pairs = [(k, p) for k, p in enumerate(pairs) if p.key in keys]
        rows = 1500 if config.quick else 16_000
        self.data = labelled_data(scene, rows, config.seed, Path(config.workdir) / "data",
                                  log=lambda m: None)
        base = compound_config(config.seed, config.quick)
        timing = TimingConfig(batch_poses=min(config.timing_rows, 20_000),
                              single_calls=base.timing.single_calls,
                              warmup=base.timing.warmup)
        self.base = dataclasses.replace(base, timing=timing)
        self.space = quick_compound_space() if config.quick else CompoundSpace()

    def __call__(self, trial) -> tuple[float, float, float]:
        start = time.perf_counter()
        trial.set_user_attr("worker", f"{socket.gethostname()}:{os.getpid()}")
        train = suggest_compound(trial, self.space, self.base)
        figures = []
        for k, pair in self.pairs:
            entry, _, _ = train_compound_pair(self.scene, pair, pair_columns(self.data, k),
                                              train, log=lambda m: None)
            figures.append(entry["decision"]["figures"])
        attrs = _pooled(figures, self.scene.accuracy.normal_deg)
        attrs |= {"pairs": [p.key for _, p in self.pairs],
                  "seconds": round(time.perf_counter() - start, 2)}
        for key, value in attrs.items():
            trial.set_user_attr(key, value)
        return attrs["fallback"], attrs["point_p99"], attrs["auto_us"]


def _pooled(figures: list[dict], normal_deg: float) -> dict:
    """The objectives and recorded figures of a trial's pairs."""
    rows = sum(f["rows"] for f in figures)
    fallback = sum(f["fallback_share"] * f["rows"] for f in figures) / max(1, rows)
    worst = max(max(f["depth_p99_over_tolerance"], f["point_p99_over_tolerance"])
                for f in figures)
    normal = max(f["normal_p99_deg"] for f in figures)
    missed = max(f["missed_share"] for f in figures)
    return {"fallback": fallback, "point_p99": worst,
            "auto_us": sum(f["auto_batch_us_per_pose"] for f in figures),
            "normal_p99": normal, "auto_normal_p99": normal, "auto_point_p99": worst,
            "missed_share": missed,
            "speedup_batch": min(f["speedup_batch"] for f in figures),
            "speedup_n1": min(f["speedup_n1"] for f in figures),
            "meets": bool(worst <= 1.0 and normal <= normal_deg and missed <= MISSED_MAX)}
