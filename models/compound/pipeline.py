"""The Python side of the compiled compound pipeline: poses shaped into rows, the kernels
launched by size, the answers assembled (:mod:`impactnet.models.compound.kernel_pipeline`).

* Fewer than :data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` poses: one serial call in the
  caller's thread (find, solve, gather), after one :func:`~impactnet.models.work.checkpoint`.
* More: blocks of :data:`ORACLE_CHUNK` poses (a checkpoint before each), each counted, filled
  and solved over the kernel threads (one launch at a time), then gathered.

Either way a pose's answer is the same bits (each pose is solved on its own). Poses arrive as
``(3,)``/``(4,)`` vectors or ``(n, 3)``/``(n, 4)`` rows, one row broadcast over the others;
quaternions are checked in a kernel (the NumPy error of
:func:`~impactnet.models.geometry.rotations.validate_quaternion` where one fails), positions
are not (as before: a NaN position culls every part pair).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compiled import PARALLEL_MIN_ROWS, chunks, launch, numba
from impactnet.models.compound import kernel_launch as kl
from impactnet.models.compound import kernel_pipeline as kp
from impactnet.models.compound.body_table import body_table
from impactnet.models.compound.kernel_frame import bad_quaternions
from impactnet.models.compound.kernel_narrowphase import convex_inputs_for, rows_for
from impactnet.models.compound.results import BodySummary, PartContacts, made
from impactnet.models.contacts import Contacts
from impactnet.models.geometry.rotations import validate_quaternion
from impactnet.models.work import checkpoint

#: Poses per block of a parallel solve (a block's arrays stay in the CPU caches; 1e5 poses in
#: one block cost twice as much per pose as blocks of a few thousand, measured on 40 ft
#: stacking).
ORACLE_CHUNK = 4096
#: Rows of the constant columns kept ready (``colliding``, ``confidence``, ``predictor`` of the
#: part contacts): copied, not built, for an answer of at most this many part contacts.
TEMPLATE_ROWS = 4096

_F64 = np.dtype(np.float64)
_ZERO = np.zeros(1, np.int64)  # every pose's body: the first of its set (never written)
_TRUE, _ONES = np.ones(TEMPLATE_ROWS, np.bool_), np.ones(TEMPLATE_ROWS)
_EXACT = np.full(TEMPLATE_ROWS, "exact")


def _rows(value, width: int) -> np.ndarray:
    """A pose input as C-contiguous, writable float64 rows (k, width): a view where it is one,
    else a copy (the kernels are compiled for that one type, never for another)."""
    if type(value) is not np.ndarray or value.dtype != _F64:
        value = np.asarray(value, np.float64)
    usable = value.flags.c_contiguous and value.flags.writeable
    if value.ndim == 1 and value.shape[0] == width:
        return value.reshape(1, width) if usable else value.reshape(1, width).copy()
    if value.ndim == 2 and value.shape[1] == width and usable:
        return value
    return np.array(np.atleast_2d(value), np.float64, order="C")


def pose_rows(position_a, quaternion_a, position_b, quaternion_b):
    """``((position_a, quaternion_a, position_b, quaternion_b), n)``: the four inputs as rows
    (1 or n each), checked as the NumPy oracle checked them (its errors)."""
    rows = (_rows(position_a, 3), _rows(quaternion_a, 4), _rows(position_b, 3),
            _rows(quaternion_b, 4))
    shapes = (rows[0].shape, rows[1].shape, rows[2].shape, rows[3].shape)
    n = max(shapes[0][0], shapes[1][0], shapes[2][0], shapes[3][0])
    if shapes != ((1, 3), (1, 4), (1, 3), (1, 4)):  # one pose: every check holds
        for shape, width in zip(shapes, (3, 4, 3, 4)):
            if len(shape) != 2 or shape[1] != width or shape[0] not in (1, n):
                _refused(rows, n)
    if bad_quaternions(rows[1], rows[3]):
        _refused(rows, n)
    return rows, n


def _refused(rows, n: int) -> None:
    """Raise the NumPy oracle's error for inputs the fast checks refused."""
    for quaternion in (rows[1], rows[3]):
        validate_quaternion(quaternion)
    for row, width in zip(rows, (3, 4, 3, 4)):
        np.broadcast_to(row, (n, width))
    raise ValueError("poses: shapes (3,)/(4,) or (n, 3)/(n, 4) expected")


def sets_of(parts_a, parts_b):
    """The packed sets of two bodies (each cached on its body table) and their tables."""
    table_a, table_b = body_table(parts_a), body_table(parts_b)
    return table_a.packed, table_b.packed, table_a, table_b


def _filled(template: np.ndarray, m: int, value) -> np.ndarray:
    return template[:m].copy() if m <= TEMPLATE_ROWS else np.full(m, value, template.dtype)


def assembled(gathered, summary):
    """(PartContacts, BodySummary) of a gather's arrays and a summary's."""
    (pose, part_a, part_b, offsets, normal, depth, point, code, feature_a, feature_b, axis,
     points, depths, count, pressure) = gathered
    m = pose.shape[0]
    contacts = made(Contacts, {
        "colliding": _filled(_TRUE, m, True), "normal": normal, "depth": depth, "point": point,
        "contact_type_code": code, "feature_a": feature_a, "feature_b": feature_b,
        "axis": axis, "manifold_points": points, "manifold_depths": depths,
        "manifold_count": count, "confidence": _filled(_ONES, m, 1.0),
        "predictor": _filled(_EXACT, m, "exact"), "pressure": pressure})
    parts = made(PartContacts, {"pose": pose, "part_a": part_a, "part_b": part_b,
                                "contacts": contacts, "offsets": offsets})
    colliding, normal, depth, point, size = summary
    return parts, made(BodySummary, {"colliding": colliding, "normal": normal, "depth": depth,
                                     "point": point, "cluster_size": size})


def sliced(rows: tuple, start: int, stop: int) -> tuple:
    """Rows start..stop of inputs of 1 or n rows each (one row broadcast)."""
    return tuple(r if r.shape[0] == 1 else r[start:stop] for r in rows)


def blocks_of(rows: int) -> int:
    """Blocks of poses of a parallel launch: a few per thread (poses differ in cost)."""
    return max(1, min(rows, 8 * numba.get_num_threads()))


def _solved_block(buffers, index, rows, n: int, found=None):
    """The gather's and the summary's arrays of n poses over the kernel threads (candidates
    found here unless given)."""
    if found is None:
        counts = np.empty(n, np.int64)
        launch(kl.count_parallel, *buffers, *index, *rows, counts, 0, n, blocks_of(n))
        offsets = np.zeros(n + 1, np.int64)
        np.cumsum(counts, out=offsets[1:])
        cand_a, cand_b = np.empty(offsets[-1], np.int64), np.empty(offsets[-1], np.int64)
        launch(kl.fill_parallel, *buffers, *index, *rows, offsets, cand_a, cand_b, 0, n,
               blocks_of(n))
        found = (offsets, cand_a, cand_b)
    m = int(found[0][-1])
    out, inputs = rows_for(m), convex_inputs_for(m)
    kept_rows, kept, summary = np.empty(m, np.int64), np.empty(n, np.int64), kp.summary_for(n)
    launch(kl.solve_parallel, *buffers, *index, *rows, *found, *out, *inputs, kept_rows, kept,
           *summary, 0, n, blocks_of(n))
    return kp.gather(found, out, kept_rows, kept), summary


def solved(set_a, set_b, rows: tuple, n: int, index=(_ZERO, _ZERO)):
    """(PartContacts, BodySummary) of n poses (rows of :func:`pose_rows`) of the bodies
    ``index`` (each 1 or n rows: the pose's body in each set)."""
    if n < PARALLEL_MIN_ROWS:
        checkpoint()
        return assembled(*kp.answer_serial(*set_a.buffers, *set_b.buffers, *index, *rows, n))
    buffers = set_a.buffers + set_b.buffers
    pieces = [assembled(*_solved_block(buffers, sliced(index, start, stop),
                                       sliced(rows, start, stop), stop - start))
              for start, stop in chunks(n, ORACLE_CHUNK)]
    return joined_answers(pieces)


def solved_given(set_a, set_b, rows: tuple, n: int, found, index=(_ZERO, _ZERO)):
    """(PartContacts, BodySummary) of n poses of given candidates (``found``: offsets (n + 1,),
    parts of A, parts of B; int64, the bodies' own part indices)."""
    if n < PARALLEL_MIN_ROWS:
        checkpoint()
        return assembled(*kp.answer_given(*set_a.buffers, *set_b.buffers, *index, *rows,
                                          *found))
    return assembled(*_solved_block(set_a.buffers + set_b.buffers, index, rows, n, found))


def counted(set_a, set_b, rows: tuple, n: int, index=(_ZERO, _ZERO)) -> np.ndarray:
    """(n,) int64: the broadphase's candidate part pairs of each pose."""
    counts = np.empty(n, np.int64)
    buffers = set_a.buffers + set_b.buffers
    if n < PARALLEL_MIN_ROWS:
        kl.count_serial(buffers, *index, rows, counts, 0, n)
    else:
        launch(kl.count_parallel, *buffers, *index, *rows, counts, 0, n, blocks_of(n))
    return counts


def filled(set_a, set_b, rows: tuple, n: int, offsets, index=(_ZERO, _ZERO)):
    """(part_a, part_b) (int64, the bodies' own indices) of every pose's candidates, at
    ``offsets`` (n + 1,)."""
    cand_a, cand_b = np.empty(offsets[-1], np.int64), np.empty(offsets[-1], np.int64)
    buffers = set_a.buffers + set_b.buffers
    if n < PARALLEL_MIN_ROWS:
        kl.fill_serial(buffers, *index, rows, offsets, cand_a, cand_b, 0, n)
    else:
        launch(kl.fill_parallel, *buffers, *index, *rows, offsets, cand_a, cand_b, 0, n,
               blocks_of(n))
    return cand_a, cand_b


def touching(set_a, set_b, rows: tuple, n: int, index=(_ZERO, _ZERO)) -> np.ndarray:
    """(n,) bool: whether any candidate part pair of a pose touches
    (:func:`~impactnet.models.compound.kernel_launch.touching_rows`)."""
    out = np.empty(n, np.bool_)
    buffers = set_a.buffers + set_b.buffers
    for start, stop in chunks(n, ORACLE_CHUNK):
        if stop - start < PARALLEL_MIN_ROWS:
            kl.touching_serial(buffers, *index, rows, out, start, stop)
        else:
            launch(kl.touching_parallel, *buffers, *index, *rows, out, start, stop,
                   blocks_of(stop - start))
    return out


def joined_answers(pieces: list) -> tuple:
    """Consecutive blocks' (PartContacts, BodySummary) as one."""
    if len(pieces) == 1:
        return pieces[0]
    parts = joined([p for p, _ in pieces])
    summaries = [s for _, s in pieces]
    return parts, BodySummary(*(np.concatenate([getattr(s, name) for s in summaries])
                                for name in BodySummary.__dataclass_fields__))


def joined(blocks: list[PartContacts]) -> PartContacts:
    """Blocks of consecutive poses as one PartContacts."""
    shift = np.cumsum([0] + [len(b.offsets) - 1 for b in blocks[:-1]])
    start = np.cumsum([0] + [int(b.offsets[-1]) for b in blocks[:-1]])
    contacts = _in_order([(np.arange(int(b.offsets[-1])) + s, b.contacts)
                          for b, s in zip(blocks, start)], int(sum(b.offsets[-1] for b in blocks)))
    return PartContacts(np.concatenate([b.pose + d for b, d in zip(blocks, shift)]),
                        np.concatenate([b.part_a for b in blocks]),
                        np.concatenate([b.part_b for b in blocks]), contacts,
                        np.concatenate([[0]] + [b.offsets[1:] + s for b, s in zip(blocks, start)]))


def _in_order(pieces, k: int) -> Contacts:
    """The pieces' rows (each ``(rows, Contacts)``) as one Contacts of k rows, features int32."""
    if len(pieces) == 1:
        found = pieces[0][1]
        found.feature_a = found.feature_a.astype(np.int32)
        found.feature_b = found.feature_b.astype(np.int32)
        return found
    order = np.concatenate([rows for rows, _ in pieces])
    where = np.empty(k, np.int64)
    where[order] = np.arange(k)
    return concatenated([found for _, found in pieces], where)


def concatenated(pieces: list[Contacts], take: np.ndarray) -> Contacts:
    """The rows of ``pieces`` one after another, then rows ``take`` of that; features int32."""
    arrays = [found.arrays() for found in pieces]
    merged = {}
    for name in arrays[0]:
        column = np.concatenate([a[name] for a in arrays])
        if name in ("feature_a", "feature_b"):
            column = column.astype(np.int32)
        merged[name] = column[take]
    return Contacts(**merged)
