"""The stacked training loop: seeded determinism, per-group early stopping, group sampling."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from impactnet.models.learned.mlp import MLPSpec
from impactnet.training.fit.loop import FitConfig, GroupRows, fit, group_losses
from impactnet.training.fit.pair import deterministic_torch
from impactnet.training.fit.single import contact_loss
from impactnet.training.fit.torch_mlp import StackedMLP, column_statistics

TINY = FitConfig(batch_size=32, steps_per_epoch=10, max_epochs=6, patience=3, val_rows=200)


def tiny_problem(seed=0, n=600):
    """Two groups, each a smooth map R^12 -> R^7 of its own."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 12)).astype(np.float32)
    y = np.tanh(x[:, :7] * 0.5 + x[:, 7:8]).astype(np.float32)
    y[n // 2:] *= -1.0
    halves = [np.arange(n // 2), np.arange(n // 2, n)]
    train = GroupRows([h[:200] for h in halves])
    val = GroupRows([h[200:] for h in halves])
    return torch.as_tensor(x), torch.as_tensor(y), train, val


def train_tiny(seed: int, config: FitConfig = TINY):
    x, y, train, val = tiny_problem()
    gen = torch.Generator().manual_seed(seed)
    model = StackedMLP(MLPSpec("tanh", (12, 8, 7)), 2, gen)
    mean, scale = column_statistics(x.numpy())
    model.set_normalisation(mean, scale, *column_statistics(y.numpy()))
    loss = contact_loss(torch.ones(2, 7))
    with deterministic_torch():
        record = fit(model, loss, x, y, train, val, config, gen, progress=False)
    return model, record, (x, y, val, loss)


def test_seeded_training_is_deterministic():
    first, rec1, _ = train_tiny(5)
    second, rec2, _ = train_tiny(5)
    other, _, _ = train_tiny(6)
    for a, b, c in zip(first.parameters(), second.parameters(), other.parameters()):
        assert torch.equal(a, b)
        assert not torch.equal(a, c)
    assert rec1.best_val_loss == rec2.best_val_loss


def test_best_parameters_are_restored():
    model, record, (x, y, val, loss) = train_tiny(1, TINY.scaled(max_epochs=12))
    index, mask = val.padded(TINY.val_rows)
    again = group_losses(model, loss, x, y, index, mask)
    np.testing.assert_allclose(again.numpy(), record.best_val_loss, rtol=1e-6)
    assert record.epochs_run >= max(record.best_epoch)
    assert record.stopped_by in ("early stopping", "epoch cap")


def test_group_rows_sample_only_their_own_rows():
    rows = GroupRows([np.array([3, 4]), np.array([10]), np.arange(20, 30)])
    drawn = rows.sample(500, torch.Generator().manual_seed(0)).numpy()
    assert set(drawn[0]) == {3, 4} and set(drawn[1]) == {10}
    assert set(drawn[2]) <= set(range(20, 30)) and len(set(drawn[2])) == 10


def test_group_rows_refuse_empty_groups():
    with pytest.raises(ValueError):
        GroupRows([np.array([1]), np.array([], dtype=np.int64)])
