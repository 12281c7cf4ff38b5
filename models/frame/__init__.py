"""A frame of the simulation in one call (issue #34): every contact among many bodies, and the
gap before contact. The bodies (:mod:`~impactnet.models.frame.bodies`) go through the compiled
broadphase over bodies (:mod:`~impactnet.models.frame.broadphase`), which finds the pairs that
may touch or lie within a margin; each pair is then answered by the one dispatcher
(:mod:`~impactnet.models.frame.solve`)."""
from impactnet.models.frame.bodies import Bodies, DuplicateBodyId
from impactnet.models.frame.broadphase import TooManyBodyPairs
from impactnet.models.frame.solve import (
    FrameAnswer,
    FramePairs,
    answer_frame,
    frame_answer,
    frame_pairs,
)

__all__ = ["Bodies", "DuplicateBodyId", "FrameAnswer", "FramePairs", "TooManyBodyPairs",
           "answer_frame", "frame_answer", "frame_pairs"]
