"""Frozen multilayer perceptrons in NumPy: the inference side of the learned predictors.

Tensors are those of the bundle contract (docs/learned_predictors.md), float32: for an MLP
named ``m``, ``m.w0, m.b0, ..., m.w{k}, m.b{k}`` (weights ``(out, in)`` like
``torch.nn.Linear``), ``m.in_mean, m.in_scale`` (inputs are ``(x - in_mean) / in_scale``) and
``m.out_mean, m.out_scale`` (outputs are ``y * out_scale + out_mean``). Hidden layers apply
the activation (``tanh`` or ``relu``); the last layer is linear.

Forward pass (:meth:`MLP.forward`). At load time the input normalisation is folded into the
first layer (``W0 / in_scale``, ``b0 - W0 in_mean / in_scale``) and the output scaling into
the last (``out_scale W``, ``out_scale b + out_mean``), and every layer is stored transposed
with its bias as an extra last row, ``(in + 1, out)`` C-contiguous. Activations carry a
trailing column of ones, so a layer is one ``h @ W`` (BLAS sgemm on row-major rows, bias
included, written into the leading columns of the next buffer) and one in-place activation:
no separate pass for the bias (25-30 % faster than matmul + add on one core). Rows go through
in blocks of :data:`FORWARD_CHUNK` so that a block's activations stay in the CPU cache. The
folding changes the result by float32 rounding only (tested against the plain formula).
:class:`MLPStack` runs K MLPs (a committee) as batched matmuls. The spec (:class:`MLPSpec`,
:mod:`impactnet.models.learned.mlp_spec`) and the kernels
(:mod:`impactnet.models.learned.mlp_kernels`) live in their own modules
and are re-exported here.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.learned.mlp_kernels import augment, dense_layer, hidden_buffers, one_row
from impactnet.models.learned.mlp_spec import ACTIVATIONS, NORM_NAMES, MLPError, MLPSpec

__all__ = ["ACTIVATIONS", "FORWARD_CHUNK", "MLP", "MLPError", "MLPSpec", "MLPStack", "augment"]

#: Rows per block of the forward pass: a block's widest activation (rows x 64 float32 =
#: 1 MB at 4096) stays in a 1 MB L2 cache, while each BLAS / NumPy call still covers many rows.
FORWARD_CHUNK = 4096


def _frozen32(value, shape, what: str) -> np.ndarray:
    array = np.array(value, dtype=np.float32, order="C")
    if array.shape != tuple(shape):
        raise MLPError(f"{what}: expected shape {tuple(shape)}, got {array.shape}")
    if not np.isfinite(array).all():
        raise MLPError(f"{what}: not finite")
    array.setflags(write=False)
    return array


class MLP:
    """A frozen MLP (float32). Learned attributes end in ``_``.

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
        self._wa = _folded(self)
        self._relu = spec.activation == "relu"
        self._one = tuple((w[:-1], w[-1]) for w in self._wa)  # (weights, bias) per layer

    @property
    def n_in(self) -> int:
        return self.spec.layers[0]

    @property
    def n_out(self) -> int:
        return self.spec.layers[-1]

    def __call__(self, x) -> np.ndarray:
        return self.forward(x)

    def forward(self, x, out: np.ndarray | None = None) -> np.ndarray:
        """Outputs (m, n_out) float32 of inputs ``x`` (m, n_in) (cast to float32).

        ``out``, if given, is a float32 (m, n_out) array to write into (returned).
        """
        return self.forward_augmented(augment(x, self.n_in), out)

    def forward_augmented(self, xa: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """As :meth:`forward`, from inputs ``xa`` (m, n_in + 1) float32 whose last column
        is 1 (see :func:`augment`)."""
        m = xa.shape[0]
        out = np.empty((m, self.n_out), np.float32) if out is None else out
        buffers = hidden_buffers(min(m, FORWARD_CHUNK), self.spec.layers[1:-1])
        for start in range(0, m, FORWARD_CHUNK):
            stop = min(m, start + FORWARD_CHUNK)
            h = xa[start:stop]
            for w, buf in zip(self._wa[:-1], buffers):
                h = dense_layer(h, w, buf[:stop - start], self._relu)
            np.matmul(h, self._wa[-1], out=out[start:stop])
        return out

    def forward_one(self, x: np.ndarray) -> np.ndarray:
        """Outputs (n_out,) float32 of one input row ``x`` (n_in,) float32: the batch of one
        without the blocking machinery (a few NumPy calls per layer)."""
        return one_row(x, self._one, self._relu)

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


def _folded(mlp: MLP) -> tuple[np.ndarray, ...]:
    """Layers ``(in + 1, out)`` float32: transposed weights over the bias row, with the
    normalisations folded in (computed in float64, rounded once)."""
    w = [np.asarray(v, np.float64) for v in mlp.weights_]
    b = [np.asarray(v, np.float64) for v in mlp.biases_]
    inv = 1.0 / np.asarray(mlp.in_scale_, np.float64)
    b[0] = b[0] - w[0] @ (np.asarray(mlp.in_mean_, np.float64) * inv)
    w[0] = w[0] * inv
    scale = np.asarray(mlp.out_scale_, np.float64)
    w[-1] = w[-1] * scale[:, None]
    b[-1] = b[-1] * scale + mlp.out_mean_
    return tuple(np.ascontiguousarray(np.vstack([wk.T, bk[None]]), dtype=np.float32)
                 for wk, bk in zip(w, b))


class MLPStack:
    """K frozen MLPs run together on the same inputs (a committee).

    Members of one architecture (widths and activation) run as one batched matmul per layer;
    a committee mixing architectures runs one such batch per architecture.
    :meth:`forward` gives every member's outputs, (K, m, n_out) float32.
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
        by_arch: dict[tuple, list[int]] = {}
        for i, m in enumerate(members):
            by_arch.setdefault((m.spec.layers, m.spec.activation), []).append(i)
        self._groups = []
        for (layers, activation), index in by_arch.items():
            wa = tuple(np.stack([members[i]._wa[j] for i in index])
                       for j in range(len(layers) - 1))  # (k, in + 1, out) per layer
            rows = slice(index[0], index[-1] + 1) if index == list(
                range(index[0], index[-1] + 1)) else np.array(index)
            self._groups.append((rows, len(index), wa, layers[1:-1], activation == "relu"))
        self._one = _block_diagonal(members)

    def forward(self, x, out: np.ndarray | None = None) -> np.ndarray:
        """Member outputs (K, m, n_out) float32 of inputs ``x`` (m, n_in)."""
        return self.forward_augmented(augment(x, self.n_in), out)

    def forward_one(self, x: np.ndarray) -> np.ndarray:
        """Member outputs (K, n_out) float32 of one input row ``x`` (n_in,) float32."""
        if self._one is None:
            return np.stack([m.forward_one(x) for m in self.members])
        layers, relu = self._one
        return one_row(x, layers, relu).reshape(self.k, self.n_out)

    def forward_augmented(self, xa: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """As :meth:`forward` from inputs (m, n_in + 1) with a last column of ones; ``out``,
        if given, is a float32 (K, m, n_out) array (or view) to write into."""
        m = xa.shape[0]
        out = np.empty((self.k, m, self.n_out), np.float32) if out is None else out
        for rows, h, start, stop, group in self._hidden(xa):
            if isinstance(rows, slice):
                np.matmul(h, group[2][-1], out=out[rows, start:stop])
            else:
                out[rows, start:stop] = np.matmul(h, group[2][-1])
        return out

    def forward_columns(self, xa: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Member outputs as columns, (K, n_out, m) float32, of inputs (m, n_in + 1) with a
        last column of ones. ``out``, if given, is a float32 (K, n_out, m) array (or view) to
        write into. (The last layer runs row-major, then is transposed: BLAS is 10x slower
        writing the transposed product of a 7-wide layer directly.)"""
        m = xa.shape[0]
        out = np.empty((self.k, self.n_out, m), np.float32) if out is None else out
        for rows, h, start, stop, group in self._hidden(xa):
            out[rows, :, start:stop] = np.matmul(h, group[2][-1]).transpose(0, 2, 1)
        return out

    def _hidden(self, xa: np.ndarray):
        """(member rows, last hidden activations (k, rows, width + 1), start, stop, group) per
        architecture group and block of rows."""
        m = xa.shape[0]
        for group in self._groups:
            rows, k, wa, widths, relu = group
            buffers = hidden_buffers(min(m, FORWARD_CHUNK), widths, (k,))
            for start in range(0, m, FORWARD_CHUNK):
                stop = min(m, start + FORWARD_CHUNK)
                h = xa[start:stop]
                for w, buf in zip(wa[:-1], buffers):
                    h = dense_layer(h, w, buf[:, :stop - start], relu)
                if not buffers:  # a single linear layer: broadcast the inputs to k members
                    h = np.broadcast_to(h, (k, *h.shape))
                yield rows, h, start, stop, group


def _block_diagonal(members):
    """One-row layers of a stack as one wide MLP: the first layers side by side, the later
    ones block-diagonal, so that a row is a few vector-matrix products whatever K (None when
    the members differ in depth or activation)."""
    if len({(len(m.spec.layers), m.spec.activation) for m in members}) != 1:
        return None
    layers = []
    for j in range(len(members[0].spec.layers) - 1):
        parts = [m._one[j] for m in members]
        if j == 0:
            w = np.concatenate([p[0] for p in parts], axis=1)
        else:
            w = np.zeros((sum(p[0].shape[0] for p in parts), sum(p[0].shape[1] for p in parts)),
                         np.float32)
            r = c = 0
            for p in parts:
                w[r:r + p[0].shape[0], c:c + p[0].shape[1]] = p[0]
                r, c = r + p[0].shape[0], c + p[0].shape[1]
        layers.append((w, np.concatenate([p[1] for p in parts])))
    return tuple(layers), members[0].spec.activation == "relu"
