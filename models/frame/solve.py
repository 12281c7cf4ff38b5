"""A frame in one call: the broadphase over the bodies, then the one dispatcher on the pairs it
finds; the answer keeps the pairs that touch or lie within the margin.

    from impactnet.models.dispatch import Dispatcher
    from impactnet.models.frame import Bodies, answer_frame

    frame = answer_frame(Dispatcher(), bodies, margin=0.5)
    for (i, j), distance in zip(frame.index, frame.answers.body["distance"]):
        print(bodies.ids[i], bodies.ids[j], distance)

Every pair of a frame answers exactly what the pairwise dispatcher answers for it with the same
margin: a pair is a row of :class:`~impactnet.models.dispatch.Pairs`, body A the one that comes
first in the frame's order (a registered world's bodies first).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.dispatch import Answers, Pairs
from impactnet.models.dispatch.plan import Caps
from impactnet.models.frame.bodies import Bodies
from impactnet.models.frame.broadphase import body_pairs


@dataclass(frozen=True)
class FramePairs:
    """The pairs of bodies the broadphase keeps: indices and the dispatcher's rows."""

    index: np.ndarray  # (k, 2) int64 body indices, the lower first, sorted
    pairs: Pairs  # k rows: A = index[:, 0], B = index[:, 1]


@dataclass(frozen=True)
class FrameAnswer:
    """The pairs of a frame that touch or lie within the margin, and their answers."""

    bodies: Bodies
    index: np.ndarray  # (k, 2) int64 body indices (A first)
    pairs: Pairs  # their k rows
    answers: Answers  # their k answers

    @property
    def ids(self) -> tuple[np.ndarray, np.ndarray]:
        """(ids of A (k,), ids of B (k,)) as str arrays."""
        ids = np.asarray(self.bodies.ids, dtype=str)
        return ids[self.index[:, 0]], ids[self.index[:, 1]]


def frame_pairs(bodies: Bodies, margin: float = 0.0, allowed: np.ndarray | None = None,
                max_pairs: int | None = None) -> FramePairs:
    """The pairs of ``bodies`` whose bounds meet within ``margin`` (m) and whose filter lets
    them touch (:func:`~impactnet.models.frame.broadphase.body_pairs`).

    ``allowed`` (s, s) bool over ``bodies.shapes``, optional: the pairs of shapes that may
    touch (a scene's list of pairs); ``max_pairs``: raise
    :class:`~impactnet.models.frame.broadphase.TooManyBodyPairs` past it.
    """
    centre, half = bodies.envelopes
    index = body_pairs(centre, half, bodies.position, bodies.rotation, margin,
                       bodies.contype, bodies.conaffinity, bodies.static, max_pairs)
    if allowed is not None and len(index):
        keep = np.asarray(allowed, bool)[bodies.shape[index[:, 0]], bodies.shape[index[:, 1]]]
        index = index[keep]
    a, b = index[:, 0], index[:, 1]
    pairs = Pairs(bodies.shapes, bodies.shape[a], bodies.shape[b], bodies.position[a],
                  bodies.quaternion[a], bodies.position[b], bodies.quaternion[b])
    return FramePairs(index, pairs)


def kept(answers: Answers) -> np.ndarray:
    """Rows (k,) that touch or lie within the margin (their distance is finite)."""
    return np.flatnonzero(answers.body["colliding"] | np.isfinite(answers.body["distance"]))


def answer_frame(dispatcher, bodies: Bodies, mode: str = "exact", margin: float = 0.0,
                 include=(), caps: Caps = Caps(), allowed: np.ndarray | None = None,
                 max_pairs: int | None = None) -> FrameAnswer:
    """Every pair of ``bodies`` that touches or lies within ``margin`` (m), answered by
    ``dispatcher`` (an :class:`~impactnet.models.dispatch.Dispatcher`) in ``mode``."""
    found = frame_pairs(bodies, margin, allowed, max_pairs)
    answers = dispatcher.answer(found.pairs, mode, include, margin, caps, separated=False)
    return frame_answer(bodies, found, answers)


def frame_answer(bodies: Bodies, found: FramePairs, answers: Answers) -> FrameAnswer:
    """The frame's answer from the answers of all the pairs the broadphase found."""
    rows = kept(answers)
    pairs = found.pairs
    taken = Pairs(pairs.shapes, *(pairs.column(c)[rows] for c in (
        "shape_a", "shape_b", "position_a", "quaternion_a", "position_b", "quaternion_b")))
    return FrameAnswer(bodies, found.index[rows], taken, answers.take(rows))
