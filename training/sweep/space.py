"""The search space of `impactnet sweep`: which training settings a trial draws, and how.

:func:`suggest` draws a trial's settings with Optuna's ``suggest_*`` calls and returns the
:class:`impactnet.training.fit.pair.PairTrainConfig` they make, built from a base config with
``dataclasses.replace`` (everything not searched stays as in the base: the seed, the splits,
the single MLP, early stopping). The same function rebuilds the config of a finished trial
from its stored parameters (:func:`config_from_params`, through ``optuna.trial.FixedTrial``), so
a pick is trained with exactly what the trial drew.

Parameters (the paper's tuned ones, plus the committee's size and the data volume):

=================  ======================================  ==================================
name               what                                    where
=================  ======================================  ==================================
``width``          hidden width of every expert layer      ``CommitteeConfig.expert_hidden``
``depth``          hidden layers of every expert           ``CommitteeConfig.expert_hidden``
``members``        committee size K (experts per region)   ``CommitteeConfig.members``
``learning_rate``  initial step size of the experts' fit   ``expert_fit.learning_rate``
``momentum``       the fit's momentum (Adam beta1)         ``expert_fit.momentum``
``rows``           labelled rows drawn per pair            ``PairDataConfig.rows``
=================  ======================================  ==================================

The classifier's width is not searched: the committee's region classifier is the exact labeller
(:mod:`impactnet.models.learned.region_label`), which has no width. The fields the space needs are
checked at import, so a rename fails loudly here rather than as a silently ignored parameter.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from impactnet.training.fit.committee import CommitteeConfig
from impactnet.training.fit.loop import FitConfig
from impactnet.training.fit.pair import PairTrainConfig

#: CommitteeConfig fields the space always sets.
REQUIRED_COMMITTEE_FIELDS = frozenset({"expert_hidden", "members", "expert_fit"})
_COMMITTEE_FIELDS = frozenset(f.name for f in dataclasses.fields(CommitteeConfig))
_FIT_FIELDS = frozenset(f.name for f in dataclasses.fields(FitConfig))
if not REQUIRED_COMMITTEE_FIELDS <= _COMMITTEE_FIELDS:
    raise ImportError("impactnet.training.sweep.space: CommitteeConfig lacks "
                      f"{sorted(REQUIRED_COMMITTEE_FIELDS - _COMMITTEE_FIELDS)}; update the "
                      "search space")
if not {"learning_rate", "momentum"} <= _FIT_FIELDS:
    raise ImportError("impactnet.training.sweep.space: FitConfig lacks learning_rate or momentum")


@dataclass(frozen=True)
class SweepSpace:
    """Ranges of the searched parameters (inclusive; integer ranges and rates drawn on a log
    scale where marked)."""

    width: tuple[int, int] = (8, 48)  # expert hidden width (log scale)
    depth: tuple[int, int] = (1, 3)  # expert hidden layers
    members: tuple[int, int] = (1, 5)  # committee size K
    learning_rate: tuple[float, float] = (3e-4, 1e-2)  # experts' initial step size (log)
    momentum: tuple[float, float] = (0.80, 0.99)  # the fit's momentum (Adam beta1)
    rows: tuple[int, int] = (50_000, 300_000)  # labelled rows per pair (log scale)

    def to_dict(self) -> dict:
        """JSON-ready ranges (stored with the study)."""
        return {f.name: list(getattr(self, f.name)) for f in dataclasses.fields(self)}


def quick_space() -> SweepSpace:
    """Small networks and little data: seconds per trial (tests, smoke runs)."""
    return SweepSpace(width=(4, 16), depth=(1, 2), members=(1, 3), rows=(3000, 6000))


def suggest(trial, space: SweepSpace, base: PairTrainConfig) -> PairTrainConfig:
    """The config of ``trial`` (an ``optuna.Trial`` or ``FixedTrial``): ``base`` with the
    searched fields drawn from ``space`` (module docstring)."""
    width = trial.suggest_int("width", *space.width, log=True)
    depth = trial.suggest_int("depth", *space.depth)
    fit_changes = {"learning_rate": trial.suggest_float("learning_rate", *space.learning_rate,
                                                         log=True),
                   "momentum": trial.suggest_float("momentum", *space.momentum)}
    committee = {"expert_hidden": (width,) * depth,
                 "members": trial.suggest_int("members", *space.members),
                 "expert_fit": dataclasses.replace(base.committee.expert_fit, **fit_changes)}
    rows = trial.suggest_int("rows", *space.rows, log=True)
    return dataclasses.replace(
        base, committee=dataclasses.replace(base.committee, **committee),
        data=dataclasses.replace(base.data, rows=rows))


def config_from_params(params: dict, space: SweepSpace, base: PairTrainConfig) -> PairTrainConfig:
    """The config a finished trial with ``params`` trained (:func:`suggest`, replayed)."""
    import optuna

    return suggest(optuna.trial.FixedTrial(params), space, base)
