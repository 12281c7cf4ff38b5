"""The learned one-pair entry: the program of no pair and the row function of one pair, compiled
once for the argument types the N = 1 path passes and then closed.

:func:`one_pair_entry` is what :mod:`impactnet.models.learned.batch` calls for one pair and what
the warm-up (:mod:`impactnet.models.learned.kernels`) compiles first.
"""
from __future__ import annotations

import threading

import numpy as np

from impactnet.models.box import kernels as box_kernels
from impactnet.models.learned import kernel_pair as kp
from impactnet.models.learned.pair_runtime import program

#: The program of no pair (the rows the exact solver answers): no MLP, no region.
NO_PROGRAM = program([], np.zeros(1, np.int64), np.zeros(kp.REGION_TABLE, np.int16),
                     np.zeros(len(kp.CONSTS)))

_CLOSING = threading.Lock()
_closed = False


def one_pair_entry():
    """:func:`~impactnet.models.learned.kernel_pair.answer_one`, compiled (or loaded) for six
    (w,) float64 C-contiguous vectors, a pair program and writable one-row outputs, then closed:
    another argument type raises TypeError instead of compiling a variant (the predictors then
    take the batch path)."""
    global _closed
    if not _closed:
        with _CLOSING:
            if not _closed:
                out = box_kernels.output_arrays(1)
                kp.answer_one(*box_kernels.example_pair(), *NO_PROGRAM, kp.EXACT, False, *out,
                              np.empty((len(kp.EXTRAS), 1)))
                kp.answer_one.disable_compile()
                _closed = True
    return kp.answer_one
