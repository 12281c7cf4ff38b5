"""The compiled forward pass of frozen MLPs: every layer with its activation, one row at a time,
the same row function for one pair and for a batch (:mod:`impactnet.models.compiled`).

The weights are arrays, so the kernels take them as arguments. Any number of MLPs of any widths
and depths are *packed* (:func:`impactnet.models.learned.mlp.pack`) into three arrays, and every
kernel is compiled once, for their types, whatever the bundle:

* ``weights`` (w,) float64: layer after layer, its parameters (the bundle's float32 tensors,
  widened once at load time);
* ``layers`` (L, 4) int64: per layer, its input width, output width, the offset of its
  parameters in ``weights`` and its kind: a dense layer ``act(h @ W + b)`` (parameters: ``W``
  as ``(in, out)`` row-major, the transpose of ``torch.nn.Linear.weight``, then ``b``) with
  the activation :data:`LINEAR`, :data:`TANH` or :data:`RELU`; or the input standardisation
  :data:`STANDARDISE` ``(x - mean) / scale`` or the output scaling :data:`RESCALE`
  ``y * scale + mean`` (parameters: ``mean``, then ``scale``);
* ``members`` (M + 1,) int64: MLP m of the pack is the layers ``members[m]:members[m + 1]``.

Arithmetic: float64, the contract's formula as written (docs/learned_predictors.md: nothing
folded, so that no rounding is added). Each output of a dense layer is the sum over its inputs
in input order, then the bias (the loop over the outputs is innermost, so LLVM vectorises it
without reordering any sum). ``tanh`` is :func:`tanh`, a branch-free float64 tanh that LLVM
vectorises, within one unit of 1.0 (2.2e-16) absolute of NumPy's and 1.5e-15 relative (libm's
``tanh`` is one call per element, ten times slower). The outputs agree with the formula
evaluated by NumPy in float64 to about 1e-15 of their magnitude
(``tests/models/learned/test_mlp.py``).
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models.compiled import PARALLEL_MIN_ROWS, chunks, jit, launch, numba, parallel_jit

#: Kinds of layer (column 3 of ``layers``): dense with the activation named, or elementwise.
LINEAR, TANH, RELU, STANDARDISE, RESCALE = 0, 1, 2, 3, 4
#: Columns of ``layers``: input width, output width, offset in ``weights``, kind.
N_IN, N_OUT, AT, KIND = 0, 1, 2, 3
#: Rows per tile of the parallel kernel (one scratch allocation per tile).
TILE_ROWS = 64

#: |x| from which tanh(x) rounds to +-1 in float64 (tanh(19.06) = 1 - 5.5e-17).
_SATURATED = 20.0
#: Below this |x| tanh is its Taylor polynomial (relative error < 1e-17 there).
_SMALL = 0.125
#: Taylor coefficients of tanh(x) / x in powers of x^2 (x^0 ... x^16).
_TANH_SERIES = (1.0, -1.0 / 3.0, 2.0 / 15.0, -17.0 / 315.0, 62.0 / 2835.0,
                -1382.0 / 155925.0, 21844.0 / 6081075.0, -929569.0 / 638512875.0,
                6404582.0 / 10854718875.0)
#: exp(r) = sum r^k / k!, k <= 13: relative error < 1e-17 for |r| <= ln(2) / 2.
_EXP_SERIES = tuple(1.0 / math.factorial(k) for k in range(14))
_LOG2_E = 1.4426950408889634
_LN2_HI, _LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10


@jit
def tanh(x):
    """``tanh(x)`` (float64) without a library call or a branch, so that loops over it vectorise.

    ``|x| >= 0.125``: ``1 - 2 / (exp(2 |x|) + 1)`` with ``exp`` by Cody-Waite reduction
    (``2 |x| = k ln 2 + r``, ``|r| <= ln(2) / 2``), its Taylor polynomial of degree 13 and an
    exact power of two; below: the Taylor polynomial of tanh of degree 17. The sign is copied
    from ``x``; ``|x| >= 20`` gives +-1. ``x`` finite (the inputs and weights are checked).
    """
    a = abs(x)
    a = a if a < _SATURATED else _SATURATED
    y = a + a
    k = math.floor(y * _LOG2_E + 0.5)
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = _EXP_SERIES[13]
    for c in range(12, -1, -1):
        p = p * r + _EXP_SERIES[c]
    e = p * float(np.int64(1) << np.int64(k))
    large = 1.0 - 2.0 / (e + 1.0)
    s = a * a
    q = _TANH_SERIES[8]
    for c in range(7, -1, -1):
        q = q * s + _TANH_SERIES[c]
    t = a * q if a < _SMALL else large
    return math.copysign(t, x)


@jit
def _offsets(layers, layer, source, target):
    """The layer's (in, out, parameter offset, source, target) as uint64: indices that cannot
    be negative, so that numba adds no wraparound test to each access and LLVM vectorises the
    loops (five times faster than int64 indices on a 128-wide layer)."""
    u = np.uint64
    return (u(layers[layer, N_IN]), u(layers[layer, N_OUT]), u(layers[layer, AT]), u(source),
            u(target))


@jit
def elementwise(weights, layers, layer, h, source, target):
    """A :data:`STANDARDISE` or :data:`RESCALE` layer (parameters: ``mean``, then ``scale``)
    from ``h[source:]`` into ``h[target:]``."""
    _, n, at, source, target = _offsets(layers, layer, source, target)
    if layers[layer, KIND] == STANDARDISE:
        for j in range(n):
            h[target + j] = (h[source + j] - weights[at + j]) / weights[at + n + j]
    else:
        for j in range(n):
            h[target + j] = h[source + j] * weights[at + n + j] + weights[at + j]


@jit
def dense(weights, layers, layer, h, source, target):
    """One layer from ``h[source:source + in]`` into ``h[target:target + out]`` (disjoint):
    ``act(x @ W + b)`` for a dense layer, else :func:`elementwise`.

    Parameters
    ----------
    weights, layers : ndarray
        The pack (module docstring); ``layer`` is the row of ``layers`` to run.
    h : ndarray of float64
        The scratch holding the layer's inputs and receiving its outputs (offsets, not views:
        a view costs two atomic reference counts, more than a narrow layer's arithmetic).
    source, target : int
        Offsets of the inputs and of the outputs in ``h``.
    """
    kind = layers[layer, KIND]
    if kind >= STANDARDISE:
        elementwise(weights, layers, layer, h, source, target)
        return
    n_in, n_out, at, source, target = _offsets(layers, layer, source, target)
    for j in range(n_out):
        h[target + j] = 0.0
    for i in range(n_in):
        value, row = h[source + i], at + i * n_out
        for j in range(n_out):
            h[target + j] += value * weights[row + j]
    bias = at + n_in * n_out
    if kind == TANH:
        for j in range(n_out):
            h[target + j] = tanh(h[target + j] + weights[bias + j])
    elif kind == RELU:
        for j in range(n_out):
            value = h[target + j] + weights[bias + j]
            h[target + j] = value if value > 0.0 else 0.0
    else:
        for j in range(n_out):
            h[target + j] += weights[bias + j]


@jit
def widest(layers):
    """The widest input or output of a pack's layers (at least 1): the scratch of
    :func:`forward` is three times this."""
    width = 1
    for layer in range(layers.shape[0]):
        width = max(width, layers[layer, N_IN], layers[layer, N_OUT])
    return width


@jit
def forward(weights, layers, members, member, h, width):
    """MLP ``member`` of a pack on the inputs ``h[:n_in]``; returns the offset of its outputs in
    ``h`` (valid until the next call). ``h`` (>= 3 width,) float64 is the scratch the layers
    alternate in, ``width`` = :func:`widest` of the pack."""
    source, target = 0, width
    for layer in range(members[member], members[member + 1]):
        dense(weights, layers, layer, h, source, target)
        source, target = target, (2 * width if target == width else width)
    return source


@jit
def _forward_row(weights, layers, members, first, x, out, row, h, width):
    """Members ``first, first + 1, ...`` (as many as ``out`` has) on row ``row`` of ``x``."""
    for k in range(out.shape[0]):
        for c in range(x.shape[1]):
            h[c] = x[row, c]
        at = forward(weights, layers, members, first + k, h, width)
        for j in range(out.shape[2]):
            out[k, row, j] = h[at + j]


@jit
def forward_rows(weights, layers, members, first, x, out, start, stop):
    """Rows ``start:stop`` of inputs ``x`` (n, n_in) float64 through the K MLPs ``first ...
    first + K - 1`` of a pack, into ``out`` (K, n, n_out) float64, serially."""
    width = widest(layers)
    h = np.empty(3 * width)
    for row in range(start, stop):
        _forward_row(weights, layers, members, first, x, out, row, h, width)


@parallel_jit
def forward_rows_parallel(weights, layers, members, first, x, out, start, stop):
    """:func:`forward_rows` over the kernel threads, a tile of :data:`TILE_ROWS` rows at a time
    (launch it with :func:`impactnet.models.compiled.launch`)."""
    width = widest(layers)
    tiles = (stop - start + TILE_ROWS - 1) // TILE_ROWS
    for tile in numba.prange(tiles):
        h = np.empty(3 * width)
        for row in range(start + tile * TILE_ROWS, min(stop, start + (tile + 1) * TILE_ROWS)):
            _forward_row(weights, layers, members, first, x, out, row, h, width)


def run_rows(serial, parallel, n: int, *args) -> None:
    """Run a rows kernel pair (``kernel(*args, start, stop)``) over n rows: serially below
    :data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` rows, else in chunks
    (:func:`~impactnet.models.compiled.chunks`: the calling context's work limit is checked
    between them), each over the kernel threads (:func:`~impactnet.models.compiled.launch`)."""
    if n < PARALLEL_MIN_ROWS:
        serial(*args, 0, n)
        return
    for start, stop in chunks(n):
        if stop - start >= PARALLEL_MIN_ROWS:
            launch(parallel, *args, start, stop)
        else:
            serial(*args, start, stop)
