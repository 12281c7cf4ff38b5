"""The ``committee`` of a pair: K experts per region, trained together.

The region classifier is the exact labeller :mod:`impactnet.models.learned.region_label` (the exact
solver's separating-axis test and incident-feature rule, without the clipping): it has nothing to
learn, and it agrees with the exact solver on every row, where a learned classifier reached 70 %
(pose-v1) to 99.7 % (SAT-derived inputs, docs/classifier_study.md). The regions with a committee are
the pair's region classes (:attr:`impactnet.training.data.pair_data.PairData.regions`, "none"
first); rows of rarer regions are answered by the exact solver at inference.

Experts (:func:`train_experts`): for every region class r >= 1, K members
``pose-v1 -> contact-residual-v1`` trained on that region's rows only, with the loss of
:func:`impactnet.training.fit.single.contact_loss`. The point they learn is the residual of the
exact point from the labeller's unclipped point (the depth-weighted mean of the touching incident
vertices; :meth:`impactnet.training.data.pair_data.PairData.expert_targets`): zero wherever the
reference face does not clip the incident feature, so the experts learn the clipping only. The
normal and depth come from the exact labeller at inference, so they enter the loss only as auxiliary
targets (weight ``CommitteeConfig.expert_aux_weight`` relative to the point). All R x K experts of
the pair are one :class:`impactnet.training.fit.torch_mlp.StackedMLP` with group
``g = r_index * K + member``: one Adam step trains all of them, each member draws its own initial
weights and its own batches (the committee's diversity comes from initialisation and sampling order;
no bootstrap, so no member loses rows), each region keeps its own normalisation, and each group is
early-stopped on its region's validation rows. :func:`export_committee` writes every (region,
member) as its own MLP.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from impactnet.models.learned import canonical as cn
from impactnet.models.learned.mlp import MLPSpec
from impactnet.models.scenes import Accuracy
from impactnet.training.data.pair_data import PairData
from impactnet.training.fit.loop import FitConfig, FitRecord, GroupRows, fit
from impactnet.training.fit.single import contact_loss, loss_weights, output_tolerances
from impactnet.training.fit.torch_mlp import StackedMLP, column_statistics, input_statistics


@dataclass(frozen=True)
class CommitteeConfig:
    """Architecture and training of a pair's experts."""

    expert_hidden: tuple[int, ...] = (24, 24)  # expert hidden widths (bundle size: about
    # 220 face regions x 3 members in the default scene, ~1.1k parameters each)
    expert_activation: str = "tanh"  # expert hidden activation (smooth regression)
    members: int = 3  # K experts per region
    expert_fit: FitConfig = field(default_factory=lambda: FitConfig(
        batch_size=256, steps_per_epoch=200, max_epochs=80, patience=20,
        learning_rate=3e-3, val_rows=4096))  # experts' optimisation (all groups at once)
    expert_aux_weight: float = 0.1  # loss weight of the normal and depth columns relative
    # to the point's (they are auxiliary: inference takes both from the exact labeller)

    def expert_spec(self) -> MLPSpec:
        """Manifest entry of every expert."""
        return MLPSpec(self.expert_activation,
                       (cn.N_POSE_FEATURES, *self.expert_hidden, cn.N_CONTACT_OUTPUTS),
                       cn.FEATURES_VERSION, cn.EXPERT_OUTPUTS_VERSION)


def _expert_rows(data: PairData, split: str, members: int) -> list[np.ndarray]:
    """Rows of every group g = r_index * K + member: each region's rows, K times."""
    return [rows for rows in data.region_rows(split) for _ in range(members)]


def train_experts(data: PairData, accuracy: Accuracy, config: CommitteeConfig,
                  generator: torch.Generator, progress: bool | None = None,
                  desc: str = "experts") -> tuple[StackedMLP | None, FitRecord]:
    """Train the K experts of every region class together (module docstring).

    A region without validation rows is validated on its training rows (rare in practice:
    classes need ``min_region_rows`` training rows). A pair without any region class (little
    data, or every point exact) has no experts: returns ``(None, FitRecord())``.
    """
    train = _expert_rows(data, "train", config.members)
    val = [v if len(v) else t for v, t in zip(_expert_rows(data, "val", config.members), train)]
    groups = len(train)
    if groups == 0:
        return None, FitRecord()
    model = StackedMLP(config.expert_spec(), groups, generator)
    targets = data.expert_targets()
    stats = [input_statistics(data.features[r]) + column_statistics(targets[r])
             for r in train]
    in_mean, in_scale, out_mean, out_scale = (np.stack(s) for s in zip(*stats))
    model.set_normalisation(in_mean, in_scale, out_mean, out_scale)
    weights = loss_weights(out_scale, output_tolerances(accuracy, data.scale, data.edge))
    weights[:, 3:] *= config.expert_aux_weight
    x, y = torch.as_tensor(data.features), torch.as_tensor(targets)
    record = fit(model, contact_loss(weights), x, y, GroupRows(train), GroupRows(val),
                 config.expert_fit, generator, desc=desc, progress=progress)
    return model, record


def expert_names(prefix: str, regions: list[str], members: int) -> dict[str, list[str]]:
    """MLP names of the experts: ``{region: ["<prefix>_r<i>_m<j>", ...]}`` for regions 1.."""
    return {region: [f"{prefix}_r{i}_m{j}" for j in range(members)]
            for i, region in enumerate(regions[1:], start=1)}


def export_committee(prefix: str, regions: list[str], experts: StackedMLP | None,
                     config: CommitteeConfig):
    """Tensors, ``mlps`` entries and the pair's ``classifier`` / ``experts`` blocks.

    Returns
    -------
    tensors : dict of str -> ndarray
    mlps : dict of str -> dict
        Manifest ``mlps`` entries of every exported network.
    blocks : dict
        ``{"classifier": {"labeller", "regions"}, "experts": {region: [names]}}``.
    """
    tensors, mlps = {}, {}
    names = expert_names(prefix, regions, config.members)
    spec = config.expert_spec().to_dict()
    for g, name in enumerate(n for region in regions[1:] for n in names[region]):
        tensors.update(experts.export(g, name))
        mlps[name] = spec
    blocks = {"classifier": {"labeller": cn.REGION_LABELLER, "regions": list(regions)},
              "experts": names}
    return tensors, mlps, blocks
