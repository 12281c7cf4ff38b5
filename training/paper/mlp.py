"""The paper's network: a 6 x h1 x h2 x 4 MLP, tanh hidden units, linear outputs, trained by
backpropagation with momentum and stopped early on the validation set.

Inputs and targets are standardised with the training set's mean and standard deviation
(:class:`Standardiser`); the loss is the mean squared error of the standardised targets, so the
four outputs weigh alike. Plain ``torch.optim.SGD`` with momentum over shuffled mini-batches;
after every epoch the validation loss is measured, and training stops ``patience`` epochs after
its best value, restoring the weights of that epoch. CPU, float32, deterministic for a seed.
"""
from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import nn


@dataclass
class MLPConfig:
    n_inputs: int = 6  # relative position (3) + Euler angles (3)
    hidden: tuple[int, int] = (20, 18)  # the paper: 6x20x18x4 with, 6x20x17x4 without discont.
    n_outputs: int = 4  # the paper's four angles


@dataclass
class PaperTrainConfig:
    learning_rate: float = 0.01  # SGD step size (on the standardised MSE)
    momentum: float = 0.9  # SGD momentum ("momentum constant" of the paper)
    batch_size: int = 32  # patterns per update (mini-batch backpropagation)
    max_epochs: int = 1000  # hard cap on passes over the training set
    patience: int = 60  # epochs without a new best validation loss before stopping
    min_delta: float = 1e-5  # relative improvement that counts as a new best
    seed: int = 0  # torch seed: initial weights and the shuffling order
    time_limit_s: float = float("inf")  # wall-clock cap of one training run, seconds


class Standardiser:
    """Per-column ``(x - mean) / std`` with the training set's statistics (std floored)."""

    def __init__(self, data: np.ndarray, floor: float = 1e-8):
        self.mean = data.mean(axis=0)
        std = data.std(axis=0)
        self.std = np.where(std > floor, std, 1.0)  # a constant column passes through centred

    def forward(self, x: np.ndarray) -> np.ndarray:
        return (x - self.mean) / self.std

    def inverse(self, z: np.ndarray) -> np.ndarray:
        return z * self.std + self.mean


def build_mlp(config: MLPConfig) -> nn.Sequential:
    """``Linear - tanh - Linear - tanh - Linear`` with PyTorch's default initialisation."""
    h1, h2 = config.hidden
    return nn.Sequential(nn.Linear(config.n_inputs, h1), nn.Tanh(), nn.Linear(h1, h2), nn.Tanh(),
                         nn.Linear(h2, config.n_outputs))


@dataclass
class TrainedMLP:
    """A trained network with its standardisers and the record of its training."""

    net: nn.Sequential
    x_scale: Standardiser
    y_scale: Standardiser
    config: PaperTrainConfig
    best_epoch: int = 0  # epoch (1-based) whose weights were restored
    epochs_run: int = 0  # epochs actually run
    best_val_loss: float = float("inf")  # standardised validation MSE at best_epoch
    seconds: float = 0.0  # wall-clock training time
    stopped_by: str = ""  # "early stopping", "epoch cap", "time limit" or "divergence"
    history: dict = field(default_factory=dict)  # "train_loss", "val_loss" per epoch

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Outputs (n, 4) in radians for inputs (n, 6)."""
        with torch.no_grad():
            z = self.net(torch.as_tensor(self.x_scale.forward(x), dtype=torch.float32))
        return self.y_scale.inverse(z.numpy().astype(np.float64))

    def n_parameters(self) -> int:
        return sum(p.numel() for p in self.net.parameters())


def train(x_train, y_train, x_val, y_val, mlp: MLPConfig, config: PaperTrainConfig) -> TrainedMLP:
    """Fit the MLP to (x_train, y_train), early-stopped on (x_val, y_val); see the module doc."""
    torch.manual_seed(config.seed)
    generator = torch.Generator().manual_seed(config.seed)
    x_scale, y_scale = Standardiser(x_train), Standardiser(y_train)

    def tensor(a):
        return torch.as_tensor(a, dtype=torch.float32)

    xt, yt = tensor(x_scale.forward(x_train)), tensor(y_scale.forward(y_train))
    xv, yv = tensor(x_scale.forward(x_val)), tensor(y_scale.forward(y_val))
    net = build_mlp(mlp)
    optimiser = torch.optim.SGD(net.parameters(), lr=config.learning_rate,
                                momentum=config.momentum)
    loss_fn = nn.MSELoss()
    result = TrainedMLP(net, x_scale, y_scale, config,
                        history={"train_loss": [], "val_loss": []})
    best_state, since_best, start = copy.deepcopy(net.state_dict()), 0, time.perf_counter()
    n, batch = len(xt), config.batch_size
    result.stopped_by = "epoch cap"
    for epoch in range(1, config.max_epochs + 1):
        order = torch.randperm(n, generator=generator)
        total = 0.0
        for i in range(0, n, batch):
            idx = order[i:i + batch]
            optimiser.zero_grad(set_to_none=True)
            loss = loss_fn(net(xt[idx]), yt[idx])
            loss.backward()
            optimiser.step()
            total += loss.item() * len(idx)
        with torch.no_grad():
            val = loss_fn(net(xv), yv).item()
        result.history["train_loss"].append(total / n)
        result.history["val_loss"].append(val)
        result.epochs_run = epoch
        if not np.isfinite(val):
            result.stopped_by = "divergence"  # keep the best weights so far
            break
        if val < result.best_val_loss * (1.0 - config.min_delta):
            result.best_val_loss, result.best_epoch, since_best = val, epoch, 0
            best_state = copy.deepcopy(net.state_dict())
        else:
            since_best += 1
        if since_best >= config.patience:
            result.stopped_by = "early stopping"
            break
        if time.perf_counter() - start > config.time_limit_s:
            result.stopped_by = "time limit"
            break
    net.load_state_dict(best_state)
    result.seconds = time.perf_counter() - start
    return result
