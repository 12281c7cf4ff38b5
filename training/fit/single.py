"""The regression loss of the contact MLPs, and the ``single`` predictor: one MLP
``pose-v1 -> contact-v1`` per pair, the paper's design made better posed.

Loss (:func:`contact_loss`): the squared error of every output in units of its tolerance
(:func:`output_tolerances`): the point in units of the scene's point tolerance, the normal
components in units of the scene's normal tolerance (radians; a small rotation of a unit vector by
an angle moves its components by at most that angle), the depth in units of :data:`DEPTH_TOLERANCE`.
On the normalised outputs of :class:`impactnet.training.fit.torch_mlp.StackedMLP` this is an MSE
weighted per column by ``(out_scale / tolerance)^2`` (weights divided by their mean, so the loss
stays of order one); the outputs that the scene needs more exactly weigh more.

``single`` trains on the colliding rows only (its outputs have no meaning on separated rows).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch

from impactnet.models.learned import canonical as cn
from impactnet.models.learned.mlp import MLPSpec
from impactnet.models.scenes import Accuracy
from impactnet.training.data.pair_data import PairData
from impactnet.training.fit.loop import FitConfig, FitRecord, GroupRows, fit
from impactnet.training.fit.torch_mlp import StackedMLP, column_statistics, input_statistics

#: Depth tolerance of the loss, as a fraction of the pair's shortest edge (a twentieth of the
#: default scene's depth range): the depth also tells ``auto`` whether a pair is in range,
#: and a separated pair shows as a negative predicted depth.
DEPTH_TOLERANCE = 5e-4


@dataclass(frozen=True)
class SingleConfig:
    """Architecture and training of the ``single`` MLP of a pair."""

    hidden: tuple[int, ...] = (32, 32)  # hidden widths (small: single is the fast answer)
    activation: str = "tanh"  # hidden activation
    fit: FitConfig = field(default_factory=lambda: FitConfig(
        batch_size=512, steps_per_epoch=200, max_epochs=40, patience=8,
        learning_rate=3e-3))  # optimisation and early stopping

    def spec(self) -> MLPSpec:
        """The manifest entry of the network."""
        return MLPSpec(self.activation, (cn.N_POSE_FEATURES, *self.hidden,
                                         cn.N_CONTACT_OUTPUTS),
                       cn.FEATURES_VERSION, cn.OUTPUTS_VERSION)


def output_tolerances(accuracy: Accuracy, scale: float, edge: float) -> np.ndarray:
    """Tolerance of each ``contact-v1`` output in its own unit, (7,) float64.

    Parameters
    ----------
    accuracy : impactnet.models.scenes.Accuracy
        The scene's normal (degrees) and point (fraction of ``edge``) tolerances.
    scale, edge : float
        Pair scale L and shortest edge e, metres.
    """
    point = accuracy.point_fraction * edge / scale
    normal = math.radians(accuracy.normal_deg)
    return np.array([point] * 3 + [normal] * 3 + [DEPTH_TOLERANCE])


def loss_weights(out_scale: np.ndarray, tolerance: np.ndarray) -> torch.Tensor:
    """Per-group column weights (G, 7) of the normalised MSE: ``(out_scale / tol)^2``, mean 1.

    ``out_scale`` (G, 7) or (7,), in the outputs' units; ``tolerance`` (7,).
    """
    w = (np.atleast_2d(out_scale) / tolerance) ** 2
    return torch.as_tensor(w / w.mean(axis=1, keepdims=True), dtype=torch.float32)


def contact_loss(weights: torch.Tensor):
    """The per-row regression loss (a :data:`impactnet.training.fit.loop.RowLoss`) with weights (G,
    7)."""
    def loss(model: StackedMLP, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        z = model.forward_normalised(model.normalise_inputs(x))
        target = (y - model.out_mean[:, None]) / model.out_scale[:, None]
        return ((z - target) ** 2 * weights[:, None, :]).mean(dim=2)
    return loss


def train_single(data: PairData, accuracy: Accuracy, config: SingleConfig,
                 generator: torch.Generator, progress: bool | None = None,
                 desc: str = "single") -> tuple[StackedMLP, FitRecord]:
    """Train the pair's single MLP on its colliding rows (one group).

    Returns
    -------
    model : StackedMLP
        One group; export it with ``model.export(0, name)``.
    record : FitRecord
    """
    train, val = data.rows("train", colliding=True), data.rows("val", colliding=True)
    model = StackedMLP(config.spec(), 1, generator)
    in_mean, in_scale = input_statistics(data.features[train])
    out_mean, out_scale = column_statistics(data.targets[train])
    model.set_normalisation(in_mean, in_scale, out_mean, out_scale)
    weights = loss_weights(out_scale, output_tolerances(accuracy, data.scale, data.edge))
    x, y = torch.as_tensor(data.features), torch.as_tensor(data.targets)
    record = fit(model, contact_loss(weights), x, y, GroupRows([train]), GroupRows([val]),
                 config.fit, generator, desc=desc, progress=progress)
    return model, record
