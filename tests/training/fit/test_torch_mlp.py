"""The stacked torch MLPs: exported members equal the stacked forward; column statistics."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from impactnet.models.learned.mlp import MLP, MLPSpec
from impactnet.training.fit.torch_mlp import (
    INPUT_SCALE_FLOOR,
    StackedMLP,
    column_statistics,
    input_statistics,
)

#: Agreement of the inference side's float32 forward pass with torch's, relative to the output
#: scale: float32 rounding of a few layers (the inference side folds the normalisations).
EXPORT_RTOL = 1e-4


@pytest.mark.parametrize("activation", ["tanh", "relu"])
def test_exported_members_equal_stacked_forward(activation):
    groups, spec = 5, MLPSpec(activation, (12, 8, 6, 7))
    model = StackedMLP(spec, groups, torch.Generator().manual_seed(3))
    rng = np.random.default_rng(0)
    model.set_normalisation(rng.normal(size=(groups, 12)), rng.uniform(0.5, 2, (groups, 12)),
                            rng.normal(size=(groups, 7)), rng.uniform(0.1, 3, (groups, 7)))
    x = torch.as_tensor(rng.normal(size=(groups, 50, 12)), dtype=torch.float32)
    with torch.no_grad():
        stacked = model(x).numpy()
    for g in range(groups):
        tensors = model.export(g, f"m{g}")
        assert all(v.dtype == np.float32 for v in tensors.values())
        assert tensors[f"m{g}.w0"].shape == (8, 12)  # (out, in), like torch.nn.Linear
        member = MLP.from_tensors(f"m{g}", tensors, spec)
        scale = np.abs(stacked[g]).max()
        np.testing.assert_allclose(member(x[g].numpy()), stacked[g], rtol=0,
                                   atol=EXPORT_RTOL * scale)


def test_groups_are_independent():
    """Changing one group's parameters leaves every other group's outputs unchanged."""
    model = StackedMLP(MLPSpec("tanh", (4, 5, 3)), 3, torch.Generator().manual_seed(0))
    x = torch.randn(3, 10, 4, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        before = model(x).clone()
        model.weights[0][1] += 1.0
        after = model(x)
    assert torch.equal(before[0], after[0]) and torch.equal(before[2], after[2])
    assert not torch.equal(before[1], after[1])


def test_column_statistics_floor_constant_columns():
    x = np.column_stack([np.arange(10.0), np.full(10, 3.0)])
    mean, scale = column_statistics(x)
    np.testing.assert_allclose(mean, [4.5, 3.0])
    assert scale[0] == pytest.approx(np.arange(10.0).std()) and scale[1] == 1.0


def test_input_scales_never_amplify_float32_rounding():
    """A feature nearly constant in a region (spread 1e-7, float32 rounding level) gets the
    floor as its scale, so rounding moves the normalised input by less than 1e-4."""
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.normal(size=1000), 1.0 - np.abs(rng.normal(size=1000)) * 1e-7])
    mean, scale = input_statistics(x)
    assert scale[0] == pytest.approx(x[:, 0].std()) and scale[1] == INPUT_SCALE_FLOOR
    assert np.float32(6e-8) / scale[1] < 1e-4
