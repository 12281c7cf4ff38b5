"""Pruning of a sweep's trials: a trial stops between its pairs when it is already worse than
most completed trials at the same step."""
from __future__ import annotations

import numpy as np


def hopeless(value: float, others: list[float], startup: int, percentile: float) -> bool:
    """True where ``value`` (lower is better) is worse than the ``percentile`` percentile of
    ``others`` (the completed trials' values at the same step), once there are ``startup``."""
    if len(others) < max(1, startup):
        return False
    return bool(value > np.percentile(np.asarray(others, dtype=float), percentile))


def completed_values(study, key: str) -> list[float]:
    """``key`` user attribute of every complete trial that has it."""
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    return [t.user_attrs[key] for t in trials if key in t.user_attrs]
