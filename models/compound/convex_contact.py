"""The exact contact of two convex parts, compiled: :func:`contact_rows` solves a range of rows
(each one pair of hulls at one relative pose; one row: ``stop = start + 1``), the kernel other
kernels call (the compound oracle's narrowphase); :func:`convex_contacts` answers m poses of
the same two hulls, :func:`stacked_contacts` m rows naming their hulls in two
:class:`~impactnet.models.compound.hull_stack.HullTable` (a row's answer is the same bits
either way: alone or in a batch, in one thread or several).

The convex counterpart of :func:`impactnet.models.box.exact.box_box`, with its conventions
(docs/design.md): the separating-axis test and tie rule of
:mod:`impactnet.models.compound.convex_sat`, the centre of pressure of
:mod:`impactnet.models.compound.convex_face` for face axes, the midpoint of the edges' closest
points for edge axes. Works in A's body frame (``t = R_A^T (p_B - p_A)``, ``R = R_A^T R_B``,
:func:`relative_poses`), so far from the origin the answer is the same as at it, and maps the
answer to the world.

Answers are :class:`impactnet.models.contacts.Contacts` rows, with two differences from the box
solver's: ``feature_a``/``feature_b`` are hull feature ids (:mod:`impactnet.models.compound.hull`,
int32: a 256-sided twistlock has 1,538 features), and ``axis`` is -1 (a hull has no fixed axis
numbering). A box part's hull keeps the box's feature ids.

The rows run stage by stage (the separating-axis test of every row of the range, then every row's
contact). A row whose hull index is negative is skipped (a box part pair among the compound
pipeline's candidates), and without ``full`` a separated row stops at its first separating axis
(:func:`~impactnet.models.compound.convex_sat.sat_rows`): only its ``colliding`` is then meaningful.
:func:`stacked_contacts` runs the rows in chunks (:func:`impactnet.models.compiled.chunks`), in the
caller's thread below :data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` rows, else over the
kernel threads (:func:`impactnet.models.compiled.launch`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.compiled import jit, on_warm_up, parallel_jit
from impactnet.models.compound.contact_row import row_contact, tables_of, to_world
from impactnet.models.compound.convex_face import FaceWork, face_work
from impactnet.models.compound.convex_sat import (
    SatWork,
    axis_rows,
    choose_axis,
    chunk_rows,
    prange,
    run_rows,
    sat_rows,
    sat_work,
    stacked,
    work_counts,
)
from impactnet.models.compound.hull import Hull, box_hull
from impactnet.models.compound.hull_stack import HullTable
from impactnet.models.contacts import Contacts

__all__ = ["ContactRows", "Work", "chunk_rows", "contact_rows", "convex_contacts",
           "make_work", "relative_poses", "stacked_contacts", "work_sizes"]


class ContactRows(NamedTuple):
    """The output arrays of m rows (fields of :class:`~impactnet.models.contacts.Contacts`
    but ``axis``, ``confidence`` and ``predictor``)."""

    colliding: np.ndarray  # (m,) bool
    normal: np.ndarray  # (m, 3)
    depth: np.ndarray  # (m,)
    point: np.ndarray  # (m, 3)
    contact_type_code: np.ndarray  # (m,) int8
    feature_a: np.ndarray  # (m,) int32
    feature_b: np.ndarray  # (m,) int32
    manifold_points: np.ndarray  # (m, 8, 3)
    manifold_depths: np.ndarray  # (m, 8)
    manifold_count: np.ndarray  # (m,) int8
    pressure: np.ndarray  # (m,)


def contact_rows_for(m: int) -> ContactRows:
    """Output arrays for m rows."""
    return ContactRows(np.zeros(m, np.bool_), np.zeros((m, 3)), np.zeros(m), np.zeros((m, 3)),
                       np.zeros(m, np.int8), np.full(m, -1, np.int32), np.full(m, -1, np.int32),
                       np.zeros((m, ct.MAX_MANIFOLD_POINTS, 3)),
                       np.zeros((m, ct.MAX_MANIFOLD_POINTS)), np.zeros(m, np.int8), np.zeros(m))


class Work(NamedTuple):
    """A thread's scratch for :func:`contact_rows`."""

    sat: SatWork
    face: FaceWork


@jit
def make_work(vertices, faces, edges, nodes, loop):
    """A :class:`Work` for hulls of at most these counts (:func:`work_sizes`)."""
    return Work(sat_work(vertices, faces, edges, nodes), face_work(vertices, faces, loop))


def work_sizes(table_a: HullTable, table_b: HullTable) -> tuple[int, int, int, int, int]:
    """(vertices, faces, edges, nodes, loop): the arguments of :func:`make_work` for two
    tables."""
    return (*work_counts(table_a, table_b), max(table_a.widest["L"], table_b.widest["L"]))


@jit
def contact_rows(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start, stop, work, full):
    """The contacts of rows start..stop (module docstring), written to ``out`` at their own
    index, world frame.

    Parameters
    ----------
    ta, tb : HullArrays
        The tables' arrays (:attr:`HullTable.arrays`) of A's and B's hulls.
    ia, ib : ndarray of int64, shape (m,)
        Each row's hulls in the tables; rows with ``ia[k] < 0`` are skipped (not written).
    t, rot : ndarray, shapes (m, 3) and (m, 3, 3)
        B's body origin and rotation in A's body frame (:func:`relative_poses`: the answers'
        bits start there).
    position_a, rot_a : ndarray, shapes (m, 3) and (m, 3, 3)
        A's body origin and rotation in the world (C-contiguous rows).
    out : ContactRows
        Every field of rows start..stop is written; ``axis`` (-1), ``confidence`` and
        ``predictor`` are the caller's.
    start, stop : int
        The rows; one row: ``stop = start + 1``.
    work : Work
        The calling thread's scratch (:func:`make_work` with :func:`work_sizes` of the tables).
    full : bool
        Every row's whole answer; False: a separated row's ``colliding`` only (module
        docstring).
    """
    # Stage 1: the separating-axis test of every row (convex_sat.sat_rows).
    axis = axis_rows(stop - start)
    sat_rows(ta, ia, tb, ib, t, rot, axis, start, start, stop, work.sat, full)
    # The tables' arrays, once per call (a tuple's array read costs a reference count, which
    # the kernel threads would contend for).
    tables_a, tables_b = tables_of(ta), tables_of(tb)
    for k in range(start, stop):
        if ia[k] < 0:
            continue
        # Stage 2: the contact of the row, A's frame; stage 3: to the world.
        row_contact(tables_a, ia[k], tables_b, ib[k], t, rot, axis, k - start, out, k, work)
        if full or out.colliding[k]:
            to_world(position_a, rot_a, out, k)


@parallel_jit
def _contact_rows_parallel(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start, stop, sizes,
                           blocks):
    """:func:`contact_rows` over the kernel threads, ``blocks`` blocks of rows, a scratch
    each."""
    n = stop - start
    for b in prange(blocks):
        work = make_work(sizes[0], sizes[1], sizes[2], sizes[3], sizes[4])
        contact_rows(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start + b * n // blocks,
                     start + (b + 1) * n // blocks, work, True)


@jit
def _contact_rows_serial(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start, stop, work):
    """:func:`contact_rows` in this thread, every row's whole answer."""
    contact_rows(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start, stop, work, True)


def convex_contacts(hull_a: Hull, hull_b: Hull, position_a, rot_a, position_b,
                    rot_b) -> Contacts:
    """Contacts of m poses of two convex parts.

    Parameters
    ----------
    hull_a, hull_b : Hull
        The parts, each in its body's frame.
    position_a, position_b : ndarray, shape (m, 3)
        The bodies' origins in the world (metres).
    rot_a, rot_b : ndarray, shape (m, 3, 3)
        The bodies' rotations.

    Returns
    -------
    Contacts
        m rows, world frame, normal from A's part towards B's.
    """
    return stacked_contacts(hull_a, None, hull_b, None, position_a, rot_a, position_b, rot_b)


def relative_poses(position_a, rot_a, position_b, rot_b) -> tuple[np.ndarray, np.ndarray]:
    """(t (m, 3), R (m, 3, 3)): B's pose in A's body frame, ``R_A^T (p_B - p_A)`` and
    ``R_A^T R_B``, computed as the NumPy solver computed them (NumPy's einsum over a transposed
    view sums in order, its matmul fuses multiply-adds: the answers' bits start here)."""
    ra_t = np.asarray(rot_a, np.float64).transpose(0, 2, 1)
    t = np.einsum("nij,nj->ni", ra_t, np.asarray(position_b, np.float64)
                  - np.asarray(position_a, np.float64))
    return t, ra_t @ np.asarray(rot_b, np.float64)


def stacked_contacts(stack_a: HullTable | Hull, index_a, stack_b: HullTable | Hull, index_b,
                     position_a, rot_a, position_b, rot_b) -> Contacts:
    """Contacts of m rows, row i of A's part ``stack_a.hulls[index_a[i]]`` and B's part
    ``stack_b.hulls[index_b[i]]`` (a :class:`Hull` and index None: that hull for every row;
    arguments otherwise as :func:`convex_contacts`)."""
    m = len(position_a)
    ta, ia = stacked(stack_a, index_a, m)
    tb, ib = stacked(stack_b, index_b, m)
    t, rot = relative_poses(position_a, rot_a, position_b, rot_b)
    out = contact_rows_for(m)
    args = (ta.arrays, ia, tb.arrays, ib, np.ascontiguousarray(t), np.ascontiguousarray(rot),
            np.ascontiguousarray(position_a, np.float64),
            np.ascontiguousarray(rot_a, np.float64), out)
    run_rows(_contact_rows_serial, _contact_rows_parallel, make_work, m, chunk_rows(ta, tb), args,
             work_sizes(ta, tb))
    return Contacts(colliding=out.colliding, normal=out.normal, depth=out.depth,
                    point=out.point, contact_type_code=out.contact_type_code,
                    feature_a=out.feature_a, feature_b=out.feature_b,
                    axis=np.full(m, -1, np.int8), manifold_points=out.manifold_points,
                    manifold_depths=out.manifold_depths, manifold_count=out.manifold_count,
                    pressure=out.pressure)


@on_warm_up(serving=False)  # the pipeline's warm-up compiles what requests call
def warm_up() -> None:
    """Compile (or load) every convex kernel: contacts and the separating-axis test alone, in
    this thread and over the kernel threads, on two small boxes."""
    from impactnet.models.compiled import PARALLEL_MIN_ROWS

    box = box_hull((1.0, 1.0, 1.0))
    for m in (1, PARALLEL_MIN_ROWS):
        position = np.zeros((m, 3))
        position_b = np.tile([0.0, 0.0, 0.9], (m, 1))
        rot = np.tile(np.eye(3), (m, 1, 1))
        convex_contacts(box, box, position, rot, position_b, rot)
        choose_axis(box, box, position_b, rot)
