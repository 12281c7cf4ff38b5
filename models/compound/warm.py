"""The compound pipeline's warm-up (registered with :func:`impactnet.models.compiled.on_warm_up`
when :mod:`impactnet.models.compound.kernels` imports this module): every compiled entry of the
oracle called once for every argument type its Python entries pass, so that no request pays a
compilation. The entries shape every input into one type (C-contiguous, writable float64 rows
and int64 indices; read-only packed sets), so one call each suffices; a test checks that
requests of every shape add no signature afterwards."""
from __future__ import annotations

import numpy as np

from impactnet.models.compiled import PARALLEL_MIN_ROWS, on_warm_up


def _bodies():
    """A small body with a two-piece group (a box and a convex part) and a lone box, and a
    second body of one box: every stage's paths (groups and their members, box and convex
    pairs, a covered surface), a few parts each."""
    from impactnet.models.compound.body_table import TransientParts
    from impactnet.models.compound.parts import BoxPart, ConvexPart, validate_parts

    wedge = ConvexPart("post/cap", ((-0.1, -0.1, 1.0), (0.1, -0.1, 1.0), (0.1, 0.1, 1.0),
                                    (-0.1, 0.1, 1.0), (0.0, 0.0, 1.2)))  # on the stem's top
    a = validate_parts("warm a", [BoxPart("base", (2.0, 2.0, 1.0)),
                                  BoxPart("post/stem", (0.2, 0.2, 0.5), (0.0, 0.0, 0.75)),
                                  wedge])
    b = validate_parts("warm b", [BoxPart("block", (1.0, 1.0, 1.0))])
    return TransientParts(a), TransientParts(b)


@on_warm_up
def warm_up() -> None:
    """Compile (or load) every entry of the compound pipeline: the answer of one pose, a small
    and a large batch, the touching test, the count and fill of candidates and the solve of
    given candidates serially and over the kernel threads, the summary of given part contacts,
    the broadphase of rotation matrices, and an input refused by the kernel's checks."""
    from impactnet.models.compound import broadphase, candidates, oracle, summary
    from impactnet.models.compound.answer import compound_answer
    from impactnet.models.compound.body_table import body_table

    a, b = _bodies()
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    for n in (1, PARALLEL_MIN_ROWS):
        position = np.tile([0.3, 0.2, 0.95], (n, 1))
        answer = compound_answer(a, np.zeros(3), identity, b, position, identity)
        oracle.compound_touching(a, np.zeros(3), identity, b, position, identity)
        found = candidates.candidate_pairs(a, np.zeros(3), identity, b, position, identity)
        candidates.answer_of_poses(a, np.zeros(3), identity, b, position, identity, found, 0, n)
        summary.summarise(answer.parts)
    broadphase.broadphase(body_table(a), body_table(b), np.zeros((1, 3)), np.eye(3)[None],
                          np.eye(3)[None])
    try:
        compound_answer(a, np.zeros(3), np.zeros(4), b, np.zeros(3), identity)
    except ValueError:
        pass
