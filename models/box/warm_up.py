"""The box solver's warm-up: every box kernel compiled (or loaded from the cache) for every
argument type its Python entries pass, registered with
:func:`impactnet.models.compiled.on_warm_up` (a module of its own, above the kernels and their
entries, so that neither imports
the other back)."""
from __future__ import annotations

import numpy as np

from impactnet.models.box import decision, exact, kernels
from impactnet.models.compiled import PARALLEL_MIN_ROWS, on_warm_up


@on_warm_up
def warm_up() -> None:
    """Compile (or load from the cache) every box kernel for every argument type the Python
    entries pass: the one-pair entry (then closed), the serial and the parallel batch kernels,
    the checks and their error reports, and the views of :mod:`impactnet.models.box.decision`.
    """
    pair = kernels.example_pair()
    exact.box_box(*pair)
    for n in (2, PARALLEL_MIN_ROWS):  # serial (checks and solve in one call); parallel
        exact.box_box(*[np.repeat(value[None], n, axis=0) for value in pair])
    rows = [value[None] for value in pair]
    kernels.solve_rows(*rows, *kernels.output_arrays(1), 0, 1)  # a batch's last, short chunk
    nan = np.full(3, np.nan)
    for bad in ((nan, pair[1]), (pair[0], pair[1], pair[2][:3]), (-pair[0], pair[1])):
        try:  # not finite; a bad shape after it (earlier inputs' finiteness first); size <= 0
            exact.box_box(*bad, *pair[len(bad):])
        except ValueError:
            pass
    exact.prepare_inputs(*pair)
    decision.relative_pose(*pair)
    decision.axis_table(*pair)
    found = decision.decisions(*pair)
    decision.reference_to_world(pair, [0], found.axis, found.quad[:, 0])
    decision.single_pair(*pair)
    decision.box_box_matrices(pair[0], pair[1], np.eye(3), pair[3], pair[4], np.eye(3))
