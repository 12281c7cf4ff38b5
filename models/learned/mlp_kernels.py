"""The NumPy kernels of the frozen MLPs (:mod:`impactnet.models.learned.mlp`): one dense layer with
its bias
folded into the matmul, the per-thread scratch activations, the one-row path.

Layout: activations carry a trailing column of ones and a layer's weights are ``(in + 1,
out)`` with the bias as the last row, so ``h @ W`` includes the bias; the product is written
into the leading columns of the next scratch buffer, whose last column stays 1.
"""
from __future__ import annotations

import threading

import numpy as np

from impactnet.models.learned.mlp_spec import MLPError


def one_row(h: np.ndarray, layers, relu: bool) -> np.ndarray:
    """``h @ W + b`` per layer with the activation between layers, for one row."""
    for w, b in layers[:-1]:
        h = np.dot(h, w)
        h += b
        if relu:
            np.maximum(h, 0.0, out=h)
        else:
            np.tanh(h, out=h)
    w, b = layers[-1]
    h = np.dot(h, w)
    h += b
    return h


def augment(x, n_in: int) -> np.ndarray:
    """Inputs (m, n_in) as float32 (m, n_in + 1) with a last column of ones."""
    x = np.asarray(x, dtype=np.float32)
    if x.ndim != 2 or x.shape[1] != n_in:
        raise MLPError(f"expected inputs (m, {n_in}), got {x.shape}")
    xa = np.empty((x.shape[0], n_in + 1), np.float32)
    xa[:, :n_in] = x
    xa[:, n_in] = 1.0
    return xa


def hidden_buffers(rows: int, widths, lead=()) -> list[np.ndarray]:
    """Hidden activations (lead..., rows, width + 1) float32, last column 1, as views of this
    thread's scratch arrays (kept between calls: fresh large arrays cost page faults).

    ``widths``: the hidden widths in layer order (one scratch slot each).
    """
    pool = getattr(_SCRATCH, "pool", None)
    if pool is None:
        pool = _SCRATCH.pool = []
    buffers = []
    for slot, width in enumerate(widths):
        shape = (*lead, rows, width + 1)
        size = int(np.prod(shape))
        if slot == len(pool):
            pool.append(np.empty(0, np.float32))
        if pool[slot].size < size:
            pool[slot] = np.empty(size, np.float32)
        buf = pool[slot][:size].reshape(shape)
        buf[..., width] = 1.0
        buffers.append(buf)
    return buffers


def dense_layer(h: np.ndarray, w: np.ndarray, buf: np.ndarray, relu: bool) -> np.ndarray:
    """One hidden layer: ``act(h @ w)`` into the leading columns of ``buf``; returns buf."""
    view = buf[..., :-1]
    np.matmul(h, w, out=view)
    if relu:  # an array operand: NumPy's maximum with a scalar 0 is 4x slower
        np.maximum(view, _zeros(view.shape), out=view)
    else:
        np.tanh(view, out=view)
    return buf


#: Per-thread scratch arrays of the hidden activations (see :func:`hidden_buffers`).
_SCRATCH = threading.local()
_ZEROS = np.zeros(1 << 20, np.float32)
_ZEROS.setflags(write=False)


def _zeros(shape) -> np.ndarray:
    size = int(np.prod(shape))
    return _ZEROS[:size].reshape(shape) if size <= _ZEROS.size else np.zeros(shape, np.float32)
