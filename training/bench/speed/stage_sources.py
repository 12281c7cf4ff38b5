"""Where the profile's stages come from: the stages of the compiled solvers, each a
zero-argument callable on inputs prepared here (:mod:`impactnet.training.bench.speed.stages`
times them). A fused kernel gives fewer stages than the algorithm has: the profile's "rest"
line takes what the named stages do not cover.
"""
from __future__ import annotations

import numpy as np

from impactnet.training.bench.speed.stages import PART_OF


def box_stages(args: tuple) -> tuple[dict, object]:
    """``(stages, whole)`` of the compiled box solver on the six (n, .) arguments ``args``;
    ``whole`` is ``box_box``."""
    from impactnet.models.box import exact

    return _kernel_box_stages(args), lambda: exact.box_box(*args)


def _kernel_box_stages(args: tuple) -> dict:
    """The compiled solver's stages: the inputs shaped into float64 rows; the output arrays;
    the kernels' checks and the fused row kernel over the kernel threads (frame, separating
    axes, manifold, centre of pressure, world frame: one kernel, one stage), with the checks
    alone as its part. The rest is the ``Contacts`` around the arrays."""
    from impactnet.models.box import exact, kernels
    from impactnet.models.box.kernel_inputs import first_fault

    rows, n = exact.checked_rows(*args)
    out = kernels.output_arrays(n)
    return {
        "input shaping": lambda: exact.checked_rows(*args),
        "output arrays": lambda: kernels.output_arrays(n),
        "checks and solve (fused kernel)": lambda: exact._solve(rows, n, out),
        PART_OF + "input checks": lambda: first_fault(*rows, n),
    }


def _split(found, keep: np.ndarray) -> tuple:
    """The candidates ``found`` (offsets (n + 1,), parts of A, parts of B) that ``keep`` marks,
    their offsets recounted pose by pose."""
    offsets, cand_a, cand_b = found
    pose = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))[keep]
    counts = np.bincount(pose, minlength=len(offsets) - 1)
    return (np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            np.ascontiguousarray(cand_a[keep]), np.ascontiguousarray(cand_b[keep]))


def compound_stages(parts_a, position_a, quaternion_a, parts_b, position_b,
                    quaternion_b) -> tuple[dict, object]:
    """``(stages, whole)`` of the compiled compound pipeline
    (``models/compound/pipeline.py``) on n poses (one block at most, ``ORACLE_CHUNK``): the
    inputs shaped into rows and checked; the broadphase (the count and the fill of every pose's
    candidate part pairs); the narrowphase, the covered-surface filter and the summary of the
    box part pairs alone and of the pairs with a convex part alone (one fused kernel over given
    candidates, each share on its own); and the summary again, alone, on the answer's part
    contacts. ``whole`` is ``compound_answer``; the rest is the answer's arrays."""
    from impactnet.models.compound import pipeline
    from impactnet.models.compound.answer import compound_answer
    from impactnet.models.compound.summary import summarise

    args = (parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b)
    set_a, set_b, table_a, table_b = pipeline.sets_of(parts_a, parts_b)
    rows, n = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    if n > pipeline.ORACLE_CHUNK:
        raise ValueError(f"profile at most {pipeline.ORACLE_CHUNK} poses (one block), got {n}")

    def broadphase():
        counts = pipeline.counted(set_a, set_b, rows, n)
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return (offsets, *pipeline.filled(set_a, set_b, rows, n, offsets))

    found = broadphase()
    box = table_a.is_box[found[1]] & table_b.is_box[found[2]]
    boxes, convex = _split(found, box), _split(found, ~box)
    parts = pipeline.solved(set_a, set_b, rows, n)[0]
    stages = {
        "input rows and checks": lambda: pipeline.pose_rows(position_a, quaternion_a,
                                                            position_b, quaternion_b),
        "broadphase": broadphase,
        "box parts (+ filter, summary)": lambda: pipeline.solved_given(set_a, set_b, rows, n,
                                                                        boxes),
        "convex parts (+ filter, summary)": lambda: pipeline.solved_given(set_a, set_b, rows,
                                                                           n, convex),
        PART_OF + "summary": lambda: summarise(parts),
    }
    return stages, lambda: compound_answer(*args)
