"""The compiled compound pipeline: the four stages of :mod:`impactnet.models.compound.oracle`
(broadphase, narrowphase, covered-surface filter, summary) over a block of poses, and the
kernels the Python entries launch (:mod:`impactnet.models.compound.pipeline`).

A block of poses runs stage by stage: every pose's candidates (found by the broadphase, or
given) solved into their candidate rows (box pairs one by one, the convex rows of the whole
block in one call of the convex solver), then every pose's touching rows filtered and
summarised, the rows kept listed in ``kept_rows`` from the pose's first candidate row. A
gather copies the kept rows into the answer's arrays, pose-major.

Every pose reads its bodies from two packed sets (:mod:`impactnet.models.compound.flat_tables`,
unpacked once per call or per block of a parallel launch), the body of pose p being
``index_a[p]`` of A's set and ``index_b[p]`` of B's (one entry: every pose's).

Entries: :func:`count_rows` (the broadphase's count of rows start..stop), :func:`fill_rows`
(their candidates), :func:`solve_block` (the rows of given candidates), :func:`gather`, and the
fused serial :func:`answer_serial` (one call: find, solve, gather), with parallel variants in
:mod:`impactnet.models.compound.kernel_launch`.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.compiled import jit
from impactnet.models.compound.convex_contact import make_work
from impactnet.models.compound.kernel_broadphase import pose_candidates, relative
from impactnet.models.compound.kernel_filter import hidden
from impactnet.models.compound.kernel_frame import pick, pose_frame
from impactnet.models.compound.kernel_narrowphase import (
    box_row,
    box_work,
    convex_inputs_for,
    convex_row,
    convex_rows,
    rows_for,
)
from impactnet.models.compound.kernel_summary import pose_summary
from impactnet.models.compound.kernel_tables import body_views, hull_views

#: Candidate rows allotted per pose before a serial call grows its arrays (doubling).
FIRST_CANDIDATES = 16


@jit
def unpacked(reals_a, ints_a, flags_a, reals_b, ints_b, flags_b):
    """(body views, hull views) of A's set and of B's: the tables a block reads."""
    return (body_views(reals_a, ints_a, flags_a), hull_views(reals_a, ints_a, flags_a),
            body_views(reals_b, ints_b, flags_b), hull_views(reals_b, ints_b, flags_b))


@jit
def scratch_for(tables):
    """A block's scratch: the broadphase's three (boxes, 3) arrays, the box solver's and the
    convex solver's (sized by the sets' largest bodies and hulls)."""
    wa, wb = tables[0].widest, tables[2].widest
    boxes = max(max(wa[0], wa[1]), max(wb[0], wb[1]))
    broad = (np.empty((boxes, 3)), np.empty((boxes, 3)), np.empty((boxes, 3)))
    convex = make_work(max(wa[2], wb[2]), max(wa[3], wb[3]), max(wa[4], wb[4]),
                       max(wa[5], wb[5]), max(wa[6], wb[6]))
    return broad, box_work(), convex


@jit
def summary_for(n):
    """The summary's arrays of n poses: colliding, normal, depth, point, cluster size."""
    return (np.empty(n, np.bool_), np.empty((n, 3)), np.empty(n), np.empty((n, 3)),
            np.empty(n, np.int64))


@jit
def bodies_of(index_a, index_b, p):
    """Pose p's body in each set."""
    return index_a[pick(index_a, p)], index_b[pick(index_b, p)]


@jit
def count_rows(tables, index_a, index_b, poses, counts, start, stop, broad):
    """``counts[p]``: the broadphase's candidate part pairs of poses start..stop."""
    body_a, _, body_b, _ = tables
    position_a, quaternion_a, position_b, quaternion_b = poses
    empty = np.empty(0, np.int64)
    for p in range(start, stop):
        a, b = bodies_of(index_a, index_b, p)
        frame = pose_frame(position_a, quaternion_a, position_b, quaternion_b, p)
        counts[p] = pose_candidates(body_a, a, body_b, b, relative(frame[1], frame[5], frame[3]),
                                    broad, empty, empty, 0, False)


@jit
def fill_rows(tables, index_a, index_b, poses, offsets, cand_a, cand_b, start, stop, broad):
    """The candidates of poses start..stop at ``offsets[p]`` (the bodies' own part indices)."""
    body_a, _, body_b, _ = tables
    position_a, quaternion_a, position_b, quaternion_b = poses
    for p in range(start, stop):
        a, b = bodies_of(index_a, index_b, p)
        frame = pose_frame(position_a, quaternion_a, position_b, quaternion_b, p)
        pose_candidates(body_a, a, body_b, b, relative(frame[1], frame[5], frame[3]), broad,
                        cand_a, cand_b, offsets[p], True)


@jit
def _narrowphase(tables, index_a, index_b, poses, found, rows, start, stop, scratch):
    """Stage 2 of poses start..stop: box pairs solved, convex pairs' inputs set, then the
    block's convex rows in one call."""
    body_a, hulls_a, body_b, hulls_b = tables
    offsets, cand_a, cand_b = found
    out, inputs = rows
    position_a, quaternion_a, position_b, quaternion_b = poses
    _, work_box, work_convex = scratch
    for p in range(start, stop):
        a, b = bodies_of(index_a, index_b, p)
        frame = pose_frame(position_a, quaternion_a, position_b, quaternion_b, p)
        base_a, base_b = body_a.body_part[a], body_b.body_part[b]
        for c in range(offsets[p], offsets[p + 1]):
            i, j = base_a + cand_a[c], base_b + cand_b[c]
            if body_a.is_box[i] and body_b.is_box[j]:
                inputs[0][c] = -1
                box_row(body_a, i, body_b, j, frame, out, c, work_box)
            else:
                convex_row(i, j, frame, inputs, c)
    convex_rows(hulls_a, hulls_b, inputs, out, offsets[start], offsets[stop], work_convex)


@jit
def _kept(tables, index_a, index_b, poses, found, out, kept_rows, kept, summary, start, stop):
    """Stages 3 and 4 of poses start..stop: the touching rows not on a covered surface listed
    from the pose's first candidate row in ``kept_rows``, counted in ``kept``; the summary."""
    body_a, hulls_a, body_b, hulls_b = tables
    offsets, cand_a, cand_b = found
    position_a, quaternion_a, position_b, quaternion_b = poses
    colliding = out[0]
    for p in range(start, stop):
        a, b = bodies_of(index_a, index_b, p)
        frame = pose_frame(position_a, quaternion_a, position_b, quaternion_b, p)
        base_a, base_b = body_a.body_part[a], body_b.body_part[b]
        first, count = offsets[p], 0
        for c in range(offsets[p], offsets[p + 1]):
            if colliding[c] and not hidden(out, c, base_a + cand_a[c], base_b + cand_b[c],
                                           frame, body_a, hulls_a, body_b, hulls_b):
                kept_rows[first + count] = c
                count += 1
        kept[p] = count
        pose_summary(kept_rows[first:], count, out[2], out[1], out[3], out[11], summary, p)


@jit
def solve_block(tables, index_a, index_b, poses, found, rows, kept_rows, kept, summary, start,
                stop, scratch):
    """Stages 2-4 of poses start..stop of given candidates (``found``: candidate offsets
    (n + 1,), parts of A, parts of B): each candidate's row of ``rows`` (the candidate
    outputs and the convex inputs), ``kept_rows``, ``kept`` and the summary written."""
    _narrowphase(tables, index_a, index_b, poses, found, rows, start, stop, scratch)
    _kept(tables, index_a, index_b, poses, found, rows[0], kept_rows, kept, summary, start,
          stop)


@jit
def gather(found, out, kept_rows, kept):
    """The kept rows of every pose, pose-major: (pose, part_a, part_b, offsets, then the
    contact fields of :data:`~impactnet.models.compound.kernel_narrowphase.OUTPUTS` but
    ``colliding``)."""
    offsets, cand_a, cand_b = found
    n = kept.shape[0]
    starts = np.empty(n + 1, np.int64)
    starts[0] = 0
    for p in range(n):
        starts[p + 1] = starts[p] + kept[p]
    m = starts[n]
    pose, part_a, part_b = np.empty(m, np.int64), np.empty(m, np.int16), np.empty(m, np.int16)
    fields = rows_for(m)
    for p in range(n):
        for s in range(kept[p]):
            c, w = kept_rows[offsets[p] + s], starts[p] + s
            pose[w], part_a[w], part_b[w] = p, cand_a[c], cand_b[c]
            _copy_row(out, c, fields, w)
    return (pose, part_a, part_b, starts, fields[1], fields[2], fields[3], fields[4], fields[5],
            fields[6], fields[7], fields[8], fields[9], fields[10], fields[11])


@jit
def _copy_row(out, c, to, w):
    """Candidate row c of ``out`` into row w of ``to`` (but ``colliding``)."""
    to[2][w], to[4][w], to[5][w], to[6][w] = out[2][c], out[4][c], out[5][c], out[6][c]
    to[7][w], to[10][w], to[11][w] = out[7][c], out[10][c], out[11][c]
    for k in range(3):
        to[1][w, k], to[3][w, k] = out[1][c, k], out[3][c, k]
    for m in range(ct.MAX_MANIFOLD_POINTS):
        to[9][w, m] = out[9][c, m]
        for k in range(3):
            to[8][w, m, k] = out[8][c, m, k]


@jit
def _grown(array, size):
    """``array`` in an array of at least ``size`` entries (doubled), its entries kept."""
    if array.shape[0] >= size:
        return array
    bigger = np.empty(max(size, 2 * array.shape[0]), array.dtype)
    bigger[:array.shape[0]] = array
    return bigger


@jit
def _found(tables, index_a, index_b, poses, n, broad):
    """Every pose's candidates in one pass (arrays grown as they fill): (offsets (n + 1,),
    parts of A, parts of B)."""
    body_a, _, body_b, _ = tables
    position_a, quaternion_a, position_b, quaternion_b = poses
    offsets = np.empty(n + 1, np.int64)
    offsets[0] = 0
    cand_a = np.empty(FIRST_CANDIDATES * n, np.int64)
    cand_b = np.empty(FIRST_CANDIDATES * n, np.int64)
    for p in range(n):
        a, b = bodies_of(index_a, index_b, p)
        most = ((body_a.body_part[a + 1] - body_a.body_part[a])
                * (body_b.body_part[b + 1] - body_b.body_part[b]))
        cand_a = _grown(cand_a, offsets[p] + most)
        cand_b = _grown(cand_b, offsets[p] + most)
        frame = pose_frame(position_a, quaternion_a, position_b, quaternion_b, p)
        offsets[p + 1] = offsets[p] + pose_candidates(
            body_a, a, body_b, b, relative(frame[1], frame[5], frame[3]), broad, cand_a, cand_b,
            offsets[p], True)
    return offsets, cand_a, cand_b


@jit
def answer_rows(tables, index_a, index_b, poses, found, n, scratch):
    """Stages 2-4 and the gather of n poses of given candidates, serially (``scratch``:
    :func:`scratch_for` the tables): the :func:`gather` arrays, then the summary's."""
    m = found[0][n]
    rows = (rows_for(m), convex_inputs_for(m))
    kept_rows, kept, summary = np.empty(m, np.int64), np.empty(n, np.int64), summary_for(n)
    solve_block(tables, index_a, index_b, poses, found, rows, kept_rows, kept, summary, 0, n,
                scratch)
    return gather(found, rows[0], kept_rows, kept), summary


@jit
def answer_serial(reals_a, ints_a, flags_a, reals_b, ints_b, flags_b, index_a, index_b,
                  position_a, quaternion_a, position_b, quaternion_b, n):
    """The whole pipeline for n poses in one serial call (the poses' rows broadcast): the
    :func:`gather` arrays, then the summary's."""
    tables = unpacked(reals_a, ints_a, flags_a, reals_b, ints_b, flags_b)
    poses = (position_a, quaternion_a, position_b, quaternion_b)
    scratch = scratch_for(tables)
    found = _found(tables, index_a, index_b, poses, n, scratch[0])
    return answer_rows(tables, index_a, index_b, poses, found, n, scratch)


@jit
def answer_given(reals_a, ints_a, flags_a, reals_b, ints_b, flags_b, index_a, index_b,
                 position_a, quaternion_a, position_b, quaternion_b, offsets, cand_a, cand_b):
    """Stages 2-4 of the given candidates of n poses in one serial call (``offsets`` (n + 1,),
    the bodies' own part indices): the :func:`gather` arrays, then the summary's."""
    tables = unpacked(reals_a, ints_a, flags_a, reals_b, ints_b, flags_b)
    poses = (position_a, quaternion_a, position_b, quaternion_b)
    return answer_rows(tables, index_a, index_b, poses, (offsets, cand_a, cand_b),
                       offsets.shape[0] - 1, scratch_for(tables))
