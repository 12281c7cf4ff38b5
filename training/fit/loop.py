"""The training loop of :class:`impactnet.training.fit.torch_mlp.StackedMLP`: every group at once,
each group early-stopped on its own validation rows.

Stages of :func:`fit`:

1. Each group g owns a set of training rows and of validation rows (indices into shared
   tensors); the single MLP is one group over all rows, the experts of a pair
   are one group per (region, member).
2. An epoch is ``steps_per_epoch`` Adam steps; each step draws ``batch_size`` rows per group
   uniformly with replacement from that group's rows (a small region is revisited more often,
   a large one is sampled, and every step costs the same), gathers them into (G, B, .) and
   minimises the sum over groups of the mean per-row loss. The learning rate follows a cosine
   from ``learning_rate`` down to ``learning_rate * final_lr_fraction`` over ``max_epochs``.
3. After every epoch each group's mean validation loss is measured (at most ``val_rows`` rows
   per group, fixed); a group whose loss improved by more than ``min_delta`` (relative) has its
   parameters stored; a group without a new best for ``patience`` epochs is finished.
   Training stops when every group is finished, at ``max_epochs`` or at ``time_limit_s``;
   every group gets its best parameters back.

Runs on the caller's torch threads (the callers use one) and is deterministic for a generator
seed.
"""
from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
from tqdm import tqdm

from impactnet.training.fit.torch_mlp import StackedMLP

#: Per-row loss: (model, x (G, B, in), y (G, B, ...)) -> losses (G, B).
RowLoss = Callable[[StackedMLP, torch.Tensor, torch.Tensor], torch.Tensor]


@dataclass(frozen=True)
class FitConfig:
    """Optimisation and early stopping of one :func:`fit` call."""

    batch_size: int = 512  # rows per group per Adam step
    steps_per_epoch: int = 100  # Adam steps between two validations
    max_epochs: int = 60  # hard cap on epochs
    patience: int = 10  # epochs without a new best validation loss before a group stops
    min_delta: float = 1e-3  # relative improvement of the validation loss that counts as best
    learning_rate: float = 3e-3  # Adam step size at the start of the cosine schedule
    momentum: float = 0.9  # Adam's beta1, the decay of its running mean of gradients (the
    # paper tuned SGD's momentum; this is its counterpart)
    final_lr_fraction: float = 0.01  # the cosine ends at learning_rate times this
    val_rows: int = 8192  # validation rows per group used for early stopping (first ones)
    time_limit_s: float = math.inf  # wall-clock cap of the call, seconds

    def scaled(self, **changes) -> FitConfig:
        """A copy with some fields changed (the quick mode)."""
        return dataclasses.replace(self, **changes)


@dataclass
class FitRecord:
    """What happened in one :func:`fit` call (stored in the manifest's training block)."""

    epochs_run: int = 0  # epochs actually run
    best_epoch: list[int] = field(default_factory=list)  # per group, 1-based (0: initial)
    best_val_loss: list[float] = field(default_factory=list)  # per group
    stopped_by: str = ""  # "early stopping", "epoch cap" or "time limit"
    seconds: float = 0.0  # wall-clock time of the call

    def summary(self) -> dict:
        """Compact JSON-ready form (group lists summarised when long)."""
        losses = np.asarray(self.best_val_loss)
        return {"epochs_run": self.epochs_run, "stopped_by": self.stopped_by,
                "seconds": round(self.seconds, 2), "groups": len(losses),
                "best_epoch_max": int(max(self.best_epoch, default=0)),
                "best_val_loss_mean": float(losses.mean()) if losses.size else None,
                "best_val_loss_max": float(losses.max()) if losses.size else None}


class GroupRows:
    """Row indices of every group, packed for vectorised sampling.

    Parameters
    ----------
    rows : sequence of int arrays
        ``rows[g]``: indices (into the shared data tensors) of group g; none may be empty.
    """

    def __init__(self, rows: Sequence[np.ndarray]):
        counts = np.array([len(r) for r in rows], dtype=np.int64)
        if counts.size == 0 or counts.min() < 1:
            raise ValueError("every group needs at least one row")
        self.flat = torch.as_tensor(np.concatenate(rows).astype(np.int64))
        self.offset = torch.as_tensor(np.concatenate([[0], np.cumsum(counts)[:-1]]))
        self.count = torch.as_tensor(counts)
        self.rows = [np.asarray(r, dtype=np.int64) for r in rows]

    def __len__(self) -> int:
        return len(self.rows)

    def sample(self, batch: int, generator: torch.Generator) -> torch.Tensor:
        """(G, batch) row indices, uniform with replacement within each group."""
        u = torch.rand(len(self.rows), batch, generator=generator)
        pick = (u * self.count[:, None]).long().clamp_max(self.count[:, None] - 1)
        return self.flat[self.offset[:, None] + pick]

    def padded(self, cap: int) -> tuple[torch.Tensor, torch.Tensor]:
        """The first ``cap`` rows of every group padded to one width: index (G, V), mask (G, V)."""
        width = int(min(cap, max(len(r) for r in self.rows)))
        index = np.zeros((len(self.rows), width), dtype=np.int64)
        mask = np.zeros((len(self.rows), width), dtype=bool)
        for g, r in enumerate(self.rows):
            k = min(width, len(r))
            index[g, :k], mask[g, :k] = r[:k], True
            index[g, k:] = r[0]
        return torch.as_tensor(index), torch.as_tensor(mask)


def _cosine_lr(config: FitConfig, step: int) -> float:
    """Learning rate at optimiser step ``step`` (0-based) of the cosine schedule."""
    total = max(1, config.max_epochs * config.steps_per_epoch)
    floor = config.learning_rate * config.final_lr_fraction
    phase = min(1.0, step / total)
    return floor + 0.5 * (config.learning_rate - floor) * (1.0 + math.cos(math.pi * phase))


def group_losses(model: StackedMLP, loss: RowLoss, x: torch.Tensor, y: torch.Tensor,
                 index: torch.Tensor, mask: torch.Tensor, chunk: int = 4096) -> torch.Tensor:
    """Mean per-row loss of every group over the masked rows ``index`` (G, V) -> (G,)."""
    total = torch.zeros(len(index), dtype=torch.float64)
    with torch.no_grad():
        for lo in range(0, index.shape[1], chunk):
            idx, m = index[:, lo:lo + chunk], mask[:, lo:lo + chunk]
            rows = loss(model, x[idx], y[idx])
            total += torch.where(m, rows, torch.zeros_like(rows)).sum(dim=1).double()
    return (total / mask.sum(dim=1).clamp_min(1)).float()


def _progress(config: FitConfig, desc: str, progress: bool | None) -> tqdm:
    enabled = sys.stderr.isatty() if progress is None else progress
    return tqdm(total=config.max_epochs, desc=desc, unit="epoch", disable=not enabled,
                file=sys.stderr, dynamic_ncols=True, leave=False)


def fit(model: StackedMLP, loss: RowLoss, x: torch.Tensor, y: torch.Tensor,
        train: GroupRows, val: GroupRows, config: FitConfig, generator: torch.Generator,
        desc: str = "train", progress: bool | None = None) -> FitRecord:
    """Train every group of ``model`` on its rows, early-stopped per group (module docstring).

    Parameters
    ----------
    model : StackedMLP
        G groups; normalisation buffers already set.
    loss : RowLoss
        Per-row loss of a gathered batch.
    x, y : torch.Tensor
        Shared inputs (n, in) float32 and targets (n, ...) of all rows.
    train, val : GroupRows
        G groups of row indices each.
    config : FitConfig
    generator : torch.Generator
        Seeded source of the batches.
    desc, progress
        Progress bar label; show it (None: only when stderr is a terminal).
    """
    if len(train) != model.groups or len(val) != model.groups:
        raise ValueError(f"model has {model.groups} groups, rows {len(train)} / {len(val)}")
    start = time.perf_counter()
    optimiser = torch.optim.Adam(model.parameters(), lr=config.learning_rate,
                                 betas=(config.momentum, 0.999))
    val_index, val_mask = val.padded(config.val_rows)
    groups = model.groups
    best = group_losses(model, loss, x, y, val_index, val_mask)
    record = FitRecord(best_epoch=[0] * groups, stopped_by="epoch cap")
    snapshot, since_best = model.parameter_snapshot(), torch.zeros(groups, dtype=torch.long)
    step = 0
    with _progress(config, desc, progress) as bar:
        for epoch in range(1, config.max_epochs + 1):
            for _ in range(config.steps_per_epoch):
                for group in optimiser.param_groups:
                    group["lr"] = _cosine_lr(config, step)
                idx = train.sample(config.batch_size, generator)
                optimiser.zero_grad(set_to_none=True)
                loss(model, x[idx], y[idx]).mean(dim=1).sum().backward()
                optimiser.step()
                step += 1
            current = group_losses(model, loss, x, y, val_index, val_mask)
            improved = current < best * (1.0 - config.min_delta)
            model.store(snapshot, improved)
            best = torch.where(improved, current, best)
            since_best = torch.where(improved, torch.zeros_like(since_best), since_best + 1)
            for g in torch.nonzero(improved).flatten().tolist():
                record.best_epoch[g] = epoch
            record.epochs_run = epoch
            bar.set_postfix(val=f"{best.mean().item():.3g}",
                            active=int((since_best < config.patience).sum()))
            bar.update(1)
            if bool((since_best >= config.patience).all()):
                record.stopped_by = "early stopping"
                break
            if time.perf_counter() - start > config.time_limit_s:
                record.stopped_by = "time limit"
                break
    model.restore(snapshot)
    record.best_val_loss = best.tolist()
    record.seconds = time.perf_counter() - start
    return record
