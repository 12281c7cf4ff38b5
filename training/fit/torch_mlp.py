"""Stacked MLPs in PyTorch: G independent networks of one shape, trained and run together.

The learned predictors need many small networks per body pair: a single MLP and K experts for
each of tens of canonical regions. Training them one by one spends most of the
time in Python and tiny matrix products. :class:`StackedMLP` holds G networks of the same layer
widths as parameter tensors with a leading group axis, ``w_k (G, out, in)``, ``b_k (G, out)``,
and evaluates all of them on a (G, B, in) batch with one ``torch.baddbmm`` per layer, so one
optimiser step trains every group. Groups never mix: the loss is a sum of per-group means and
Adam is elementwise, so each group follows the trajectory it would follow alone.

Every group carries the normalisation of the inference contract (docs/learned_predictors.md):
inputs ``(x - in_mean) / in_scale``, outputs ``y * out_scale + out_mean``.
:meth:`StackedMLP.export` writes group g as the contract's tensors ``<m>.w0, <m>.b0, ...,
<m>.in_mean, <m>.in_scale, <m>.out_mean, <m>.out_scale`` (float32, weights (out, in)).
"""
from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn

from impactnet.models.learned.mlp import MLPSpec

#: Hidden activations of the contract (``impactnet.models.learned.mlp.ACTIVATIONS``) as torch
#: functions.
ACTIVATIONS = {"tanh": torch.tanh, "relu": torch.relu}
#: Floor (in the column's own unit) below which a standard deviation counts as zero: the
#: column is constant (e.g. the normal of a face region) and is only centred, scale 1.
STD_FLOOR = 1e-9
#: Smallest input scale of a network (the features' own units: pose-v1 entries are O(1)).
#: Inference computes the features in float32 (rounding ~6e-8 near 1); a column that is nearly
#: constant in a region (an entry of R' near +-1 in a face-face region spreads by ~1e-7)
#: divided by its own spread would turn that rounding into whole normalised units, and the
#: answer of one pair would depend on the batch it arrives in. At 1e-3 the rounding stays
#: below 1e-4 normalised units.
INPUT_SCALE_FLOOR = 1e-3


def n_parameters(spec: MLPSpec) -> int:
    """Weights and biases of one network of ``spec``."""
    return sum((i + 1) * o for i, o in zip(spec.layers[:-1], spec.layers[1:]))


def column_statistics(x: np.ndarray, floor: float = STD_FLOOR) -> tuple[np.ndarray, np.ndarray]:
    """Mean and scale (standard deviation, 1 where below ``floor``) of the columns of x (n, d)."""
    x = np.asarray(x, dtype=np.float64)
    mean = x.mean(axis=0)
    std = x.std(axis=0)
    return mean, np.where(std > floor, std, 1.0)


def input_statistics(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and scale of network inputs (n, d): the standard deviation, at least
    :data:`INPUT_SCALE_FLOOR`."""
    x = np.asarray(x, dtype=np.float64)
    return x.mean(axis=0), np.maximum(x.std(axis=0), INPUT_SCALE_FLOOR)


class StackedMLP(nn.Module):
    """G MLPs of one :class:`impactnet.models.learned.mlp.MLPSpec`, evaluated on (G, B, in) batches.

    Parameters
    ----------
    shape : MLPSpec
        Layer widths and activation (the same for every group).
    groups : int
        Number of networks G.
    generator : torch.Generator
        Source of the initial weights: Xavier-uniform (tanh) or He-uniform (relu) weights,
        zero biases; each group draws its own.
    """

    def __init__(self, shape: MLPSpec, groups: int, generator: torch.Generator):
        super().__init__()
        self.shape, self.groups = shape, int(groups)
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        gain = 1.0 if shape.activation == "tanh" else math.sqrt(2.0)
        for fan_in, fan_out in zip(shape.layers[:-1], shape.layers[1:]):
            bound = gain * math.sqrt(6.0 / (fan_in + fan_out))
            w = (torch.rand(groups, fan_out, fan_in, generator=generator) * 2 - 1) * bound
            self.weights.append(nn.Parameter(w))
            self.biases.append(nn.Parameter(torch.zeros(groups, fan_out)))
        n_in, n_out = shape.layers[0], shape.layers[-1]
        self.register_buffer("in_mean", torch.zeros(groups, n_in))
        self.register_buffer("in_scale", torch.ones(groups, n_in))
        self.register_buffer("out_mean", torch.zeros(groups, n_out))
        self.register_buffer("out_scale", torch.ones(groups, n_out))
        self._act = ACTIVATIONS[shape.activation]

    def set_normalisation(self, in_mean, in_scale, out_mean=None, out_scale=None) -> None:
        """Set the per-group statistics; each argument (G, width) or (width,) (broadcast)."""
        for name, value in (("in_mean", in_mean), ("in_scale", in_scale),
                            ("out_mean", out_mean), ("out_scale", out_scale)):
            if value is not None:
                buffer = getattr(self, name)
                buffer.copy_(torch.as_tensor(np.asarray(value), dtype=torch.float32)
                             .expand_as(buffer))

    def normalise_inputs(self, x: torch.Tensor) -> torch.Tensor:
        """``(x - in_mean) / in_scale`` for x (G, B, in)."""
        return (x - self.in_mean[:, None]) / self.in_scale[:, None]

    def forward_normalised(self, z: torch.Tensor) -> torch.Tensor:
        """Normalised inputs z (G, B, in) -> normalised outputs (G, B, out)."""
        h = z
        last = len(self.weights) - 1
        for k, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.baddbmm(b[:, None, :], h, w.transpose(1, 2))
            if k < last:
                h = self._act(h)
        return h

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Raw inputs x (G, B, in) -> raw outputs (G, B, out)."""
        y = self.forward_normalised(self.normalise_inputs(x))
        return y * self.out_scale[:, None] + self.out_mean[:, None]

    def export(self, group: int, name: str) -> dict[str, np.ndarray]:
        """Group ``group`` as the contract's tensors named ``<name>.*`` (float32 arrays)."""
        tensors = {}
        with torch.no_grad():
            for k, (w, b) in enumerate(zip(self.weights, self.biases)):
                tensors[f"{name}.w{k}"] = w[group].numpy().astype(np.float32).copy()
                tensors[f"{name}.b{k}"] = b[group].numpy().astype(np.float32).copy()
            for stat in ("in_mean", "in_scale", "out_mean", "out_scale"):
                tensors[f"{name}.{stat}"] = getattr(self, stat)[group].numpy().copy()
        return tensors

    def parameter_snapshot(self) -> list[torch.Tensor]:
        """Copies of every parameter tensor (for restoring the best epoch)."""
        return [p.detach().clone() for p in self.parameters()]

    def restore(self, snapshot: list[torch.Tensor], groups: torch.Tensor | None = None) -> None:
        """Copy ``snapshot`` back, only into the groups selected by the bool mask (G,) if given."""
        with torch.no_grad():
            for p, saved in zip(self.parameters(), snapshot):
                if groups is None:
                    p.copy_(saved)
                else:
                    p[groups] = saved[groups]

    def store(self, snapshot: list[torch.Tensor], groups: torch.Tensor) -> None:
        """Copy the current parameters of the groups in the bool mask (G,) into ``snapshot``."""
        with torch.no_grad():
            for p, saved in zip(self.parameters(), snapshot):
                saved[groups] = p[groups]

