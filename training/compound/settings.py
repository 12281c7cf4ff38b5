"""The training configurations of compound pairs: the default and the quick one (tests)."""
from __future__ import annotations

from impactnet.training.compound.classify import ClassifierConfig
from impactnet.training.compound.experts import ExpertConfig
from impactnet.training.compound.measure import TimingConfig
from impactnet.training.compound.pair import CompoundTrainConfig
from impactnet.training.fit.loop import FitConfig


def compound_config(seed: int = 0, quick: bool = False) -> CompoundTrainConfig:
    """The default configuration, or with ``quick`` tiny networks, few epochs and short
    timings (seconds per pair; the same files and decisions' form)."""
    if not quick:
        return CompoundTrainConfig(seed=seed)
    fit = FitConfig(batch_size=128, steps_per_epoch=20, max_epochs=4, patience=2, val_rows=1024)
    return CompoundTrainConfig(
        seed=seed, classifier=ClassifierConfig(hidden=(32, 32), fit=fit),
        experts=ExpertConfig(members=2, hidden=(16, 16), min_rows=50, fit=fit),
        timing=TimingConfig(batch_poses=1000, single_calls=10, warmup=2))
