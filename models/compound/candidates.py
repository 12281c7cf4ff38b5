"""The compound oracle in two steps, for callers that must admit work before doing it.

:func:`compound_answer` runs the broadphase and the narrowphase together. A server that must
bound a request's cost first needs the broadphase's count, the cheap part, before the costly
part starts:

1. :func:`candidate_pairs`: the broadphase's surviving part pairs of N poses, counted per pose,
   in blocks of poses with a :func:`~impactnet.models.work.checkpoint` between blocks, and
   stopped early (:class:`TooManyCandidates`) once a pose or the total passes its cap;
2. :func:`answer_of_poses`: the narrowphase, the filter of covered surfaces and the summary of
   a slice of the poses, on their candidates only. Slices chosen by :func:`pose_slices` keep
   each call's work bounded, so a caller can check its deadline between them.

Both steps are compiled (:mod:`impactnet.models.compound.kernel_launch`: a count of each pose's
candidates, then the candidates themselves; the solve of given candidates), so the answer of a
slice is, bit for bit, the answer :func:`compound_answer` gives for those poses.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compiled import chunks
from impactnet.models.compound import pipeline
from impactnet.models.compound.answer import CompoundAnswer
from impactnet.models.compound.pipeline import ORACLE_CHUNK
from impactnet.models.compound.results import made

#: The work of one box part pair in the units of :func:`part_work` (8 vertices x 6 faces
#: twice, 12 x 12 edge pairs): the unit of :attr:`Candidates.work`.
BOX_PAIR_WORK = 2 * 8 * 6 + 12 * 12


def part_work(table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices, faces, edges) counts (P,) of a body table's part hulls: the sizes the
    separating-axis test's work grows with."""
    return table.hull_counts


def pair_work(table_a, table_b, i: np.ndarray, j: np.ndarray) -> float:
    """The work of the part pairs (i, j) in box part pairs (:data:`BOX_PAIR_WORK`): vertices
    against faces both ways plus edge pairs, at least 1 each."""
    va, fa, ea = part_work(table_a)
    vb, fb, eb = part_work(table_b)
    units = (va[i] * fb[j] + vb[j] * fa[i] + ea[i] * eb[j]) / BOX_PAIR_WORK
    return float(np.maximum(units, 1.0).sum())


#: Part pairs (poses x A's parts x B's parts) per block of the count: the caps are checked
#: and the work limit consulted after each block (~0.1 s of broadphase at most).
BLOCK_PART_PAIRS = 1 << 20


class TooManyCandidates(ValueError):
    """The broadphase found more candidate part pairs than a cap allows: ``pose`` (the first
    pose over the per-pose cap; None for the total), ``count`` and ``cap``."""

    def __init__(self, pose: int | None, count: int, cap: int) -> None:
        self.pose, self.count, self.cap = pose, count, cap
        where = f"pose {pose}" if pose is not None else "the poses together"
        super().__init__(f"{where}: {count} candidate part pairs, more than {cap}")


@dataclass(frozen=True)
class Candidates:
    """The broadphase survivors of N poses, pose-major (k rows)."""

    pose: np.ndarray  # (k,) int64, the pose of each candidate
    part_a: np.ndarray  # (k,) int64, index into A's parts
    part_b: np.ndarray  # (k,) int64, index into B's parts
    counts: np.ndarray  # (n,) int64, candidates per pose
    work: float  # the candidates' work in box part pairs (:func:`pair_work`)

    @property
    def total(self) -> int:
        return len(self.pose)


def _checked(counts: np.ndarray, start: int, total: int, max_per_pose, max_total) -> int:
    """The running total after a block's counts, the caps checked (the per-pose cap first)."""
    if max_per_pose is not None and counts.sum() > 0 and counts.max() > max_per_pose:
        first = int(np.argmax(counts > max_per_pose))
        raise TooManyCandidates(start + first, int(counts[first]), max_per_pose)
    total += int(counts.sum())
    if max_total is not None and total > max_total:
        raise TooManyCandidates(None, total, max_total)
    return total


def candidate_pairs(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b,
                    max_per_pose: int | None = None, max_total: int | None = None) -> Candidates:
    """The candidate part pairs of N poses of A against B (arguments as
    :func:`~impactnet.models.compound.compound_answer`).

    Parameters
    ----------
    max_per_pose, max_total : int, optional
        Caps on the candidates of one pose and of all poses; checked after each block of
        poses (at most :data:`BLOCK_PART_PAIRS` part pairs in all, so that a cap stops a
        costly request early).

    Raises
    ------
    TooManyCandidates
        A cap is passed (the block that passes it is the last one counted).
    impactnet.models.work.WorkStopped
        The calling context's work limit expired between two blocks.
    """
    set_a, set_b, table_a, table_b = pipeline.sets_of(parts_a, parts_b)
    rows, n = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    counts = np.zeros(n, np.int64)
    pieces, total = [], 0
    block = min(ORACLE_CHUNK, max(1, BLOCK_PART_PAIRS // (len(parts_a) * len(parts_b))))
    for start, stop in chunks(n, block):
        sub = pipeline.sliced(rows, start, stop)
        found = pipeline.counted(set_a, set_b, sub, stop - start)
        total = _checked(found, start, total, max_per_pose, max_total)
        counts[start:stop] = found
        offsets = np.zeros(stop - start + 1, np.int64)
        np.cumsum(found, out=offsets[1:])
        pieces.append((np.repeat(np.arange(start, stop), found),
                       *pipeline.filled(set_a, set_b, sub, stop - start, offsets)))
    pose, i, j = ((np.concatenate(c).astype(np.int64) for c in zip(*pieces)) if pieces else
                  (np.zeros(0, np.int64),) * 3)
    return Candidates(pose, i, j, counts, pair_work(table_a, table_b, i, j))


def pose_slices(counts: np.ndarray, max_candidates: int,
                max_poses: int = ORACLE_CHUNK) -> list[tuple[int, int]]:
    """Consecutive slices ``(start, stop)`` of the poses, each with at most ``max_poses``
    poses and at most ``max_candidates`` candidates (a pose with more is a slice of its own)."""
    slices, start, n = [], 0, len(counts)
    ends = np.cumsum(counts)
    while start < n:
        base = ends[start - 1] if start else 0
        stop = int(np.searchsorted(ends, base + max_candidates, side="right"))
        stop = min(max(stop, start + 1), start + max_poses, n)
        slices.append((start, stop))
        start = stop
    return slices


def answer_of_poses(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b,
                    found: Candidates, start: int, stop: int) -> CompoundAnswer:
    """The answer of poses ``start:stop`` (their rows 0..stop-start) from their candidates in
    ``found``: :func:`compound_answer`'s answer for those poses, bit for bit."""
    set_a, set_b, table_a, table_b = pipeline.sets_of(parts_a, parts_b)
    rows, _ = pipeline.pose_rows(position_a, quaternion_a, position_b, quaternion_b)
    first, last = np.searchsorted(found.pose, [start, stop])
    offsets = np.zeros(stop - start + 1, np.int64)
    np.cumsum(found.counts[start:stop], out=offsets[1:])
    given = (offsets, np.ascontiguousarray(found.part_a[first:last], np.int64),
             np.ascontiguousarray(found.part_b[first:last], np.int64))
    parts, summary = pipeline.solved_given(set_a, set_b, pipeline.sliced(rows, start, stop),
                                           stop - start, given)
    return made(CompoundAnswer, {"parts": parts, "summary": summary, "names_a": table_a.names,
                                 "names_b": table_b.names})
