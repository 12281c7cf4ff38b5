"""The ``committee`` of a pair: a region classifier and K experts per region, trained together.

Classifier (:func:`train_classifier`): ``pose-v1 -> logits`` over the pair's region classes
(:attr:`training.pair_data.PairData.regions`, ``"none"`` first), cross-entropy. Rows of regions
too rare for a class (label :data:`training.pair_data.UNSURE_LABEL`) are trained towards the
uniform distribution (cross-entropy against 1/R on every class), so that where they lie the
classifier's top probability is low and ``auto`` falls back to the exact solver, instead of
routing them with confidence to a neighbouring region's experts.

Experts (:func:`train_experts`): for every region class r >= 1, K members
``pose-v1 -> contact-v1`` trained on that region's rows only, with the loss of
:func:`training.train_single.contact_loss`. All R x K experts of the pair are one
:class:`training.torch_mlp.StackedMLP` with group ``g = r_index * K + member``: one Adam step
trains all of them, each member draws its own initial weights and its own batches (the
committee's diversity comes from initialisation and sampling order; no bootstrap, so no member
loses rows), each region keeps its own normalisation, and each group is early-stopped on its
region's validation rows. :func:`export_committee` writes every (region, member) as its own MLP.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from models import canonical as cn
from models.mlp import MLPSpec
from models.scenes import Accuracy
from training.fit import FitConfig, FitRecord, GroupRows, fit
from training.pair_data import PairData
from training.torch_mlp import StackedMLP, column_statistics
from training.train_single import contact_loss, loss_weights, output_tolerances

#: ``outputs`` entry of a classifier in the manifest (its outputs are region logits).
CLASSIFIER_OUTPUTS = "region-logits"


@dataclass(frozen=True)
class CommitteeConfig:
    """Architecture and training of a pair's classifier and experts."""

    classifier_hidden: tuple[int, ...] = (64, 64)  # classifier hidden widths
    classifier_activation: str = "relu"  # classifier hidden activation (cheap at inference)
    classifier_fit: FitConfig = field(default_factory=lambda: FitConfig(
        batch_size=512, steps_per_epoch=250, max_epochs=120, patience=30,
        learning_rate=3e-3))  # classifier optimisation
    expert_hidden: tuple[int, ...] = (16, 16)  # expert hidden widths (bundle size: ~500
    # regions x 3 members in the default scene; 20-20 made 6.8 MB)
    expert_activation: str = "tanh"  # expert hidden activation (smooth regression)
    members: int = 3  # K experts per region
    expert_fit: FitConfig = field(default_factory=lambda: FitConfig(
        batch_size=256, steps_per_epoch=200, max_epochs=45, patience=45,
        learning_rate=3e-3, val_rows=4096))  # experts' optimisation (all groups at once)

    def classifier_spec(self, n_regions: int) -> MLPSpec:
        """Manifest entry of the classifier for ``n_regions`` classes."""
        return MLPSpec(self.classifier_activation,
                       (cn.N_POSE_FEATURES, *self.classifier_hidden, n_regions),
                       cn.FEATURES_VERSION, CLASSIFIER_OUTPUTS)

    def expert_spec(self) -> MLPSpec:
        """Manifest entry of every expert."""
        return MLPSpec(self.expert_activation,
                       (cn.N_POSE_FEATURES, *self.expert_hidden, cn.N_CONTACT_OUTPUTS),
                       cn.FEATURES_VERSION, cn.OUTPUTS_VERSION)


def classifier_loss(model: StackedMLP, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Per-row cross-entropy (G, B); label -1 means the uniform target over all classes."""
    logits = model(x)
    log_norm = torch.logsumexp(logits, dim=2)
    picked = logits.gather(2, y.clamp_min(0)[..., None])[..., 0]
    return log_norm - torch.where(y >= 0, picked, logits.mean(dim=2))


def train_classifier(data: PairData, config: CommitteeConfig, generator: torch.Generator,
                     progress: bool | None = None,
                     desc: str = "classifier") -> tuple[StackedMLP, FitRecord]:
    """Train the region classifier on all training rows (one group)."""
    train, val = data.rows("train"), data.rows("val")
    model = StackedMLP(config.classifier_spec(len(data.regions)), 1, generator)
    in_mean, in_scale = column_statistics(data.features[train])
    model.set_normalisation(in_mean, in_scale)
    x, y = torch.as_tensor(data.features), torch.as_tensor(data.labels)
    record = fit(model, classifier_loss, x, y, GroupRows([train]), GroupRows([val]),
                 config.classifier_fit, generator, desc=desc, progress=progress)
    return model, record


def _expert_rows(data: PairData, split: str, members: int) -> list[np.ndarray]:
    """Rows of every group g = r_index * K + member: each region's rows, K times."""
    return [rows for rows in data.region_rows(split) for _ in range(members)]


def train_experts(data: PairData, accuracy: Accuracy, config: CommitteeConfig,
                  generator: torch.Generator, progress: bool | None = None,
                  desc: str = "experts") -> tuple[StackedMLP, FitRecord]:
    """Train the K experts of every region class together (module docstring).

    A region without validation rows is validated on its training rows (rare in practice:
    classes need ``min_region_rows`` training rows).
    """
    train = _expert_rows(data, "train", config.members)
    val = [v if len(v) else t for v, t in zip(_expert_rows(data, "val", config.members), train)]
    groups = len(train)
    model = StackedMLP(config.expert_spec(), groups, generator)
    stats = [column_statistics(data.features[r]) + column_statistics(data.targets[r])
             for r in train]
    in_mean, in_scale, out_mean, out_scale = (np.stack(s) for s in zip(*stats))
    model.set_normalisation(in_mean, in_scale, out_mean, out_scale)
    weights = loss_weights(out_scale, output_tolerances(accuracy, data.scale, data.edge))
    x, y = torch.as_tensor(data.features), torch.as_tensor(data.targets)
    record = fit(model, contact_loss(weights), x, y, GroupRows(train), GroupRows(val),
                 config.expert_fit, generator, desc=desc, progress=progress)
    return model, record


def expert_names(prefix: str, regions: list[str], members: int) -> dict[str, list[str]]:
    """MLP names of the experts: ``{region: ["<prefix>_r<i>_m<j>", ...]}`` for regions 1.."""
    return {region: [f"{prefix}_r{i}_m{j}" for j in range(members)]
            for i, region in enumerate(regions[1:], start=1)}


def export_committee(prefix: str, regions: list[str], classifier: StackedMLP,
                     experts: StackedMLP, config: CommitteeConfig):
    """Tensors, ``mlps`` entries and the pair's ``classifier`` / ``experts`` blocks.

    Returns
    -------
    tensors : dict of str -> ndarray
    mlps : dict of str -> dict
        Manifest ``mlps`` entries of every exported network.
    blocks : dict
        ``{"classifier": {"mlp", "regions"}, "experts": {region: [names]}}``.
    """
    tensors = classifier.export(0, f"{prefix}_classifier")
    mlps = {f"{prefix}_classifier": config.classifier_spec(len(regions)).to_dict()}
    names = expert_names(prefix, regions, config.members)
    spec = config.expert_spec().to_dict()
    for g, name in enumerate(n for region in regions[1:] for n in names[region]):
        tensors.update(experts.export(g, name))
        mlps[name] = spec
    blocks = {"classifier": {"mlp": f"{prefix}_classifier", "regions": list(regions)},
              "experts": names}
    return tensors, mlps, blocks
