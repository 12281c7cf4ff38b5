"""Frozen multilayer perceptrons: the inference side of the learned predictors.

Tensors are those of the bundle contract (docs/learned_predictors.md), float32: for an MLP
named ``m``, ``m.w0, m.b0, ..., m.w{k}, m.b{k}`` (weights ``(out, in)`` like
``torch.nn.Linear``), ``m.in_mean, m.in_scale`` (inputs are ``(x - in_mean) / in_scale``) and
``m.out_mean, m.out_scale`` (outputs are ``y * out_scale + out_mean``). Hidden layers apply
the activation (``tanh`` or ``relu``); the last layer is linear.

Forward pass: compiled (:mod:`impactnet.models.learned.kernel_mlp`), the formula above as
written, in float64 (the tensors widened once; nothing folded: folding the normalisations into
the weights rounds them again, up to 1e-12 of the outputs on the shipped classifiers). MLPs are
*packed* (:func:`pack`: their layers in three arrays) for the kernels, which take the weights
as arguments: :meth:`MLP.forward` runs one MLP, :class:`MLPStack` a committee, and the
predictors run whole pairs' packs (:mod:`impactnet.models.learned.pair_runtime`). The spec
(:class:`MLPSpec`) lives in :mod:`impactnet.models.learned.mlp_spec`, re-exported here.
"""
from __future__ import annotations

from functools import cached_property
from typing import NamedTuple

import numpy as np

from impactnet.models.learned import kernel_mlp as km
from impactnet.models.learned.mlp_spec import ACTIVATIONS, NORM_NAMES, MLPError, MLPSpec

__all__ = ["ACTIVATIONS", "MLP", "MLPError", "MLPSpec", "MLPStack", "Pack", "frozen", "pack"]

_ACTIVATION_CODES = {"tanh": km.TANH, "relu": km.RELU}


def _frozen32(value, shape, what: str) -> np.ndarray:
    array = np.array(value, dtype=np.float32, order="C")
    if array.shape != tuple(shape):
        raise MLPError(f"{what}: expected shape {tuple(shape)}, got {array.shape}")
    if not np.isfinite(array).all():
        raise MLPError(f"{what}: not finite")
    array.setflags(write=False)
    return array


class Pack(NamedTuple):
    """MLPs as the kernels take them (:mod:`impactnet.models.learned.kernel_mlp`)."""

    weights: np.ndarray  # (w,) float64: every layer's parameters, layer after layer
    layers: np.ndarray  # (L, 4) int64: in, out, offset in weights, kind
    members: np.ndarray  # (M + 1,) int64: MLP m is layers members[m]:members[m + 1]


def pack(mlps) -> Pack:
    """The layers of ``mlps`` (a sequence of :class:`MLP`), member m being ``mlps[m]``: the
    input standardisation, the dense layers, the output scaling."""
    blocks, layers, members = [], [], [0]
    at = 0
    for mlp in mlps:
        hidden = _ACTIVATION_CODES[mlp.spec.activation]
        last = len(mlp.weights_) - 1
        steps = [((mlp.n_in, mlp.n_in, km.STANDARDISE), (mlp.in_mean_, mlp.in_scale_))]
        steps += [((w.shape[1], w.shape[0], km.LINEAR if k == last else hidden), (w.T, b))
                  for k, (w, b) in enumerate(zip(mlp.weights_, mlp.biases_))]
        steps.append(((mlp.n_out, mlp.n_out, km.RESCALE), (mlp.out_mean_, mlp.out_scale_)))
        for (n_in, n_out, kind), parameters in steps:
            block = np.concatenate([np.asarray(p, np.float64).reshape(-1) for p in parameters])
            layers.append((n_in, n_out, at, kind))
            blocks.append(block)
            at += block.size
        members.append(len(layers))
    return Pack(*(frozen(a) for a in (np.concatenate(blocks) if blocks else np.zeros(0),
                                      np.array(layers, np.int64).reshape(-1, 4),
                                      np.array(members, np.int64))))


def frozen(array: np.ndarray) -> np.ndarray:
    """``array``, read-only: every array a kernel is given from a model is, so that each kernel
    is compiled for one set of array types (numba types read-only arrays apart)."""
    array.setflags(write=False)
    return array


def _inputs(x, n_in: int) -> np.ndarray:
    """Inputs (m, n_in) as C-contiguous float64; MLPError for another shape."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != n_in:
        raise MLPError(f"expected inputs (m, {n_in}), got {x.shape}")
    return x


def run_pack(packed: Pack, first: int, k: int, x: np.ndarray, n_out: int) -> np.ndarray:
    """Outputs (k, m, n_out) float64 of the members ``first ... first + k - 1`` of ``packed`` on
    checked inputs ``x`` (m, n_in) float64."""
    out = np.empty((k, x.shape[0], n_out))
    km.run_rows(km.forward_rows, km.forward_rows_parallel, x.shape[0], *packed, first, x, out)
    return out


class MLP:
    """A frozen MLP. Learned attributes end in ``_``.

    Parameters
    ----------
    spec : MLPSpec
    weights : sequence of array_like
        ``(layers[k + 1], layers[k])`` each, like ``torch.nn.Linear.weight``.
    biases : sequence of array_like
        ``(layers[k + 1],)`` each.
    in_mean, in_scale : array_like, shape (layers[0],)
        Input normalisation; ``in_scale`` > 0.
    out_mean, out_scale : array_like, shape (layers[-1],)
        Output de-normalisation.
    """

    def __init__(self, spec: MLPSpec, weights, biases, in_mean, in_scale, out_mean, out_scale):
        shapes = spec.shapes("mlp")
        k = len(spec.layers) - 1
        if len(weights) != k or len(biases) != k:
            raise MLPError(f"expected {k} weights and biases, got {len(weights)}, {len(biases)}")
        self.spec = spec
        self.weights_ = tuple(_frozen32(w, shapes[f"mlp.w{i}"], f"w{i}")
                              for i, w in enumerate(weights))
        self.biases_ = tuple(_frozen32(b, shapes[f"mlp.b{i}"], f"b{i}")
                             for i, b in enumerate(biases))
        self.in_mean_, self.in_scale_, self.out_mean_, self.out_scale_ = (
            _frozen32(v, shapes[f"mlp.{n}"], n)
            for v, n in zip((in_mean, in_scale, out_mean, out_scale), NORM_NAMES))
        if not (self.in_scale_ > 0).all():
            raise MLPError("in_scale must be > 0")

    @property
    def n_in(self) -> int:
        return self.spec.layers[0]

    @property
    def n_out(self) -> int:
        return self.spec.layers[-1]

    @cached_property
    def pack(self) -> Pack:
        """This MLP alone as a :class:`Pack`."""
        return pack([self])

    def __call__(self, x) -> np.ndarray:
        return self.forward(x)

    def forward(self, x) -> np.ndarray:
        """Outputs (m, n_out) float64 of inputs ``x`` (m, n_in) (cast to float64)."""
        return run_pack(self.pack, 0, 1, _inputs(x, self.n_in), self.n_out)[0]

    def to_tensors(self, name: str) -> dict[str, np.ndarray]:
        """The contract's tensors of this MLP under ``name`` (float32 copies)."""
        tensors = {}
        for k, (w, b) in enumerate(zip(self.weights_, self.biases_)):
            tensors[f"{name}.w{k}"], tensors[f"{name}.b{k}"] = w.copy(), b.copy()
        for norm in NORM_NAMES:
            tensors[f"{name}.{norm}"] = getattr(self, f"{norm}_").copy()
        return tensors

    @classmethod
    def from_tensors(cls, name: str, tensors, spec: MLPSpec | dict) -> MLP:
        """The MLP ``name`` of a tensor mapping; MLPError when a tensor is missing or misshapen.

        Tensors of other MLPs in ``tensors`` are ignored.
        """
        spec = spec if isinstance(spec, MLPSpec) else MLPSpec.from_dict(spec)
        for key, shape in spec.shapes(name).items():
            if key not in tensors:
                raise MLPError(f"MLP {name!r}: missing tensor {key!r}")
            if tuple(tensors[key].shape) != shape:
                raise MLPError(f"MLP {name!r}: tensor {key!r} has shape "
                               f"{tuple(tensors[key].shape)}, the manifest declares {shape}")
        k = len(spec.layers) - 1
        try:
            return cls(spec, [tensors[f"{name}.w{i}"] for i in range(k)],
                       [tensors[f"{name}.b{i}"] for i in range(k)],
                       *(tensors[f"{name}.{n}"] for n in NORM_NAMES))
        except MLPError as exc:
            raise MLPError(f"MLP {name!r}: {exc}") from None


class MLPStack:
    """K frozen MLPs run together on the same inputs (a committee): one pack, one kernel call.

    :meth:`forward` gives every member's outputs, (K, m, n_out) float64. The members may differ
    in depth, widths and activation, not in their input and output widths.
    """

    def __init__(self, members):
        members = tuple(members)
        if not members:
            raise MLPError("a stack needs at least one MLP")
        if len({(m.n_in, m.n_out) for m in members}) != 1:
            raise MLPError("the MLPs of a stack must share their input and output widths")
        self.members = members
        self.k = len(members)
        self.n_in, self.n_out = members[0].n_in, members[0].n_out
        self.pack = pack(members)

    def forward(self, x) -> np.ndarray:
        """Member outputs (K, m, n_out) float64 of inputs ``x`` (m, n_in)."""
        return run_pack(self.pack, 0, self.k, _inputs(x, self.n_in), self.n_out)
