"""Where a frame's time goes: ``answer_frame``'s stages, each a zero-argument callable on
inputs prepared here, for :func:`impactnet.training.bench.speed.stages.profile` (which times
them in rounds next to the whole and calls what no stage covers "rest").

In-process stages (:func:`frame_stages`), in the order ``answer_frame`` runs them:

* **bodies**: the input arrays into a :class:`~impactnet.models.frame.Bodies` and its
  rotation matrices (what a caller's frame costs before any contact);
* **broadphase**: :func:`~impactnet.models.frame.frame_pairs` (world bounds, the sweep, the
  dispatcher's rows of the pairs found);
* **plan**: the dispatcher's split of those rows (box pairs, compound groups by pair of shapes,
  the bounding-sphere test of compound rows);
* **count**: the compound oracle's part broadphase (candidate part pairs under the caps);
* **box pairs**: the box solver on the box rows (``_box_rows``);
* **compound oracle**: the candidates' narrowphase, covered-surface filter and summary, slice
  by slice (``_compound_slice``);
* **gaps**: the closest part pair of the compound pairs found apart that a frame still asks
  about (at margin 0, only those whose part bounds met: a frame drops the rest unasked);
* **frame answer**: the kept rows taken out of the answers (``frame_answer``).

The rest is the merge of the slices' answers and the glue. These are the dispatcher's private
steps (``models/dispatch/solve.py``): if they change, the profile says so instead of failing
the benchmark (``stages.profile`` catches it).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.dispatch import Caps, Dispatcher
from impactnet.models.frame import Bodies, answer_frame, frame_answer, frame_pairs


def fresh_bodies(bodies: Bodies, position: np.ndarray, quaternion: np.ndarray) -> Bodies:
    """``bodies`` at new poses: a new :class:`Bodies`, nothing cached (a caller's frame)."""
    return Bodies(bodies.ids, bodies.shapes, bodies.shape, position, quaternion,
                  bodies.contype, bodies.conaffinity, bodies.static)


def frame_call(bodies: Bodies, dispatcher: Dispatcher, margin: float = 0.0):
    """``call(position (n, 3), quaternion (n, 4)) -> FrameAnswer``: one frame of ``bodies``'
    world at those poses, from the arrays (module docstring's whole)."""
    def call(position, quaternion):
        return answer_frame(dispatcher, fresh_bodies(bodies, position, quaternion),
                            margin=margin)

    return call


def _compound(plan, caps, pieces):
    """``pieces`` with the compound slices of a counted plan solved into them."""
    from impactnet.models.compound.candidates import pose_slices
    from impactnet.models.dispatch import plan as plans
    from impactnet.models.dispatch import solve as sv

    for group in plan.groups:
        for start, stop in pose_slices(group.candidates.counts, plans.SLICE_CANDIDATES):
            sv._compound_slice(pieces, group, start, stop, plan.mode, caps)
    return pieces


def frame_stages(bodies: Bodies, dispatcher: Dispatcher, margin: float = 0.0):
    """``(stages, whole)`` of one frame of ``bodies`` (module docstring)."""
    from impactnet.models.dispatch import solve as sv
    from impactnet.models.dispatch.answers import Pieces

    caps = Caps()
    position, quaternion = bodies.position.copy(), bodies.quaternion.copy()
    found = frame_pairs(bodies, margin)
    n = len(found.pairs)
    # the plan answer_frame makes: rows apart beyond the margin get no separating direction
    plan = dispatcher.count(dispatcher.plan(found.pairs, "exact", (), margin, caps, False), caps)
    filled = _compound(plan, caps, Pieces(n))
    answers = dispatcher.solve(plan, caps)

    box = dispatcher.box_predictors["exact"]
    stages = {
        "bodies (arrays to Bodies, rotations)":
            lambda: fresh_bodies(bodies, position, quaternion).rotation,
        "broadphase (frame_pairs)": lambda: frame_pairs(bodies, margin),
        "plan (split, sphere test)": lambda: dispatcher.plan(found.pairs, "exact", (), margin,
                                                             caps, False),
        "count (part candidates)": lambda: dispatcher.count(plan, caps),
        "box pairs (box solver)": lambda: sv._box_rows(Pieces(n), plan, box, caps),
        "compound oracle (narrowphase, filter, summary)":
            lambda: _compound(plan, caps, Pieces(n)),
        "gaps (separated compound pairs)": lambda: sv._separated_gaps(filled, plan),
        "frame answer (kept rows)": lambda: frame_answer(bodies, found, answers),
    }
    whole = frame_call(bodies, dispatcher, margin)
    return stages, lambda: whole(position, quaternion)
