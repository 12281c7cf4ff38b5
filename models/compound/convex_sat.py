"""Separating-axis test of two convex polyhedra, compiled: :func:`sat_rows` tests a range of
rows (each one pair of hulls at one relative pose; one row: ``stop = start + 1``) in the
calling thread; :func:`choose_axis` answers m rows (poses of one pair of hulls, or rows naming
their hulls in two :class:`~impactnet.models.compound.hull_stack.HullTable`; a row's answer
does not depend on the others).

Frame: A's body frame. Hull A's vertices are as built (:mod:`impactnet.models.compound.hull`);
hull B's are ``y = R v + t``. Candidate axes:

* A's face normals: separation ``min_B (n . y) - h`` (B's vertices against A's plane);
* B's face normals, the same the other way round;
* for every edge of A and edge of B whose Gauss-map arcs cross (the pair spans a face of the
  Minkowski difference; Gregorius, "The Separating Axis Test between Convex Polyhedra", GDC
  2013): the cross product of the two edges, oriented away from A, separation
  ``u . (q0 - p0)`` between the two edges' lines.

The hulls touch iff no axis separates them by more than :data:`CONTACT_TOL_REL` of the pair's
scale (the sum of both hulls' largest half-extents). The contact axis follows the box solver's
tie rule (:mod:`impactnet.models.box.tolerances`) with the same constants:

1. the face axis of least overlap, ties within :data:`TIE_TOL_REL` to the lowest index (A's
   faces before B's);
2. an edge axis within :data:`FACE_AXIS_ANGLE_TOL` of that face's normal never wins: it
   competes as that face, with its own overlap where that is smaller (the face's depth stays
   its own);
3. another edge axis wins only if shallower by more than :data:`DEPTH_GAIN_TOL_REL`, and only
   where the closest points of its two edges lie inside both edges
   (:data:`EDGE_INSIDE_TOL_REL`); of equally shallow edge axes the lowest (A's edge, B's edge)
   competes.

An edge pair changes nothing unless it separates more than every face axis (``face_top``, the
largest face separation) and more than the best edge pair less the depth gain: rule 2 needs
the winner shallower than the best face by the gain, a banned pair lowers the bar only where
it is within the gain of the winner, and the colliding test and a separated row's normal take
the largest separation (ties to the lowest pair). So the search only has to evaluate every
crossing pair that may separate more than ``max(face_top, best - gain)``; the answer is then
the one of the test on every pair, bit for bit.

Search (chosen by measurement; two 256-sided heads meet with about n^2 / 2 crossing arc pairs,
all of which the NumPy solver's scan of every pair evaluated):

* Face axes: ``min_B (n . y)`` is B's support along ``-n``, found by steepest descent over B's
  vertex graph (:func:`_separations`), starting from the support of the face's parent in a
  spanning tree of nearest face normals (a step or two away). A linear function's sublevel
  sets on a convex polytope's vertex graph are connected, so a local minimum whose neighbours
  all lie above it by more than the rounding of the values is the minimum; where a neighbour
  lies within :data:`FLOOD_TOL_REL` of it (a face parallel to the searched direction: a
  many-sided head standing on a plate), every vertex within that of it is visited and the
  smallest value kept (:func:`_flood`). The value is the same floating-point expression as a
  scan of every vertex, so the minimum has the same bits. Hulls not convex to
  :data:`~impactnet.models.compound.hull_stack.CLIMB_FLAT_TOL_REL` of their size are scanned.
* Edge axes: each hull's Gauss-map arcs sit in a binary tree of spherical caps
  (:mod:`impactnet.models.compound.hull_stack`); the two trees are walked together (B's caps
  turned by ``-R``, the child of larger bound first) and a pair of nodes is dropped when its
  caps do not meet (the caps are widened far above rounding, so every pair the exact crossing
  test accepts is visited), or when neither node's bound of an edge separation
  (:func:`_edge_bounds`), plus the rounding of a computed separation (:func:`_prune_margin`),
  exceeds the bar. The rounding grows as ``1 / sin`` of the angle between the two edges: the
  nodes' cones of edge directions bound that angle where the smallest margin (any usable pair)
  is too wide. Small node pairs (:data:`PAIR_BLOCK` edge pairs) are tested pair by pair, each
  against its own edges' bounds first, then the NumPy solver's crossing test. Ties among the
  crossing pairs are broken by the lowest (A's edge, B's edge) whatever the walk's order, as
  the row-major scan did. Hulls not convex enough are walked on caps alone.

Measured (one thread, medians, ``python -m tests.models.compound.convex_bench``, four runs;
head: the spreader's twistlock head, a stadium frustum; random poses near contact; the
separating-axis test and the contact, per pair in a batch of 256, at 8 / 32 / 128 / 256
sides): the NumPy solver 43-62 / 172-200 / 600-710 / 1,250-1,610 us on a plate and 91-102 /
780-900 / 10,000-11,400 / 35,500-45,600 us on a head; the kernels 3.9-4.3 / 9.6-10.6 / 27-35 /
48-53 us on a plate and 5.1-5.2 / 14-17 / 56-59 / 130-135 us on a head. Two 256-sided heads
resting on each other (the walk's and the face clip's worst case) cost about 510 us.

Rows whose answer is needed only where they touch (the compound pipeline drops separated part
pairs; :func:`sat_rows` with ``full`` False) stop at the first axis that separates them by more
than the contact tolerance: every face of A, then of B, then the walk; their ``colliding`` is
the full test's, the rest of their row is not written. A row whose hull index is negative is
skipped (a box part pair among a block's candidates).

Stages, one module each: B in A's frame and the face axes
(:mod:`~impactnet.models.compound.sat_faces`), the edge pairs' geometry and bounds
(:mod:`~impactnet.models.compound.sat_edges`), the walk and the tie rule
(:mod:`~impactnet.models.compound.sat_walk`); the row kernel that runs them
(:mod:`~impactnet.models.compound.sat_rows`). This module: the Python entry (:func:`choose_axis`)
and the launch of row kernels (:func:`run_rows`).

Every expression sums its terms in the order of the NumPy solver it replaces (``x0 y0 + x1 y1
+ x2 y2``), so the answers keep their bits. Kernels read a table's arrays out of their tuple
once per call (each read costs a reference count, an atomic operation the kernel threads would
contend for), and hot loops call no function that takes an array.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compiled import PARALLEL_MIN_ROWS, chunks, jit, launch, numba, parallel_jit
from impactnet.models.compound.hull import Hull
from impactnet.models.compound.hull_stack import HullTable, stack_hulls
from impactnet.models.compound.sat_faces import maximum, minimum, turn
from impactnet.models.compound.sat_rows import AxisRows, SatWork, axis_rows, sat_rows, sat_work
from impactnet.models.compound.sat_walk import EDGE, FACE_A, FACE_B

__all__ = ["EDGE", "FACE_A", "FACE_B", "AxisChoice", "AxisRows", "SatWork", "axis_rows",
           "choose_axis", "chunk_rows", "maximum", "minimum", "run_rows", "sat_rows", "sat_work",
           "stacked", "turn", "work_counts"]

prange = numba.prange  # numba comes through models.compiled (its cache folder is set first)

#: Work items (rows x table entries of the pair) per chunk of rows: about 10 ms of work between
#: two checkpoints of the calling context's work limit (measured: 65 rows of two 256-sided
#: heads, 3,800 rows of two boxes).
CHUNK_ITEMS = 200_000


def work_counts(table_a: HullTable, table_b: HullTable) -> tuple[int, int, int, int]:
    """(vertices, faces, edges, nodes): the largest hull counts of two tables."""
    a, b = table_a.widest, table_b.widest
    return (max(a["V"], b["V"]), max(a["F"], b["F"]), max(a["E"], b["E"]),
            max(a["N"], b["N"]))


@dataclass
class AxisChoice:
    """The separating-axis test's answer for m poses (A's body frame)."""

    colliding: np.ndarray  # (m,) bool
    kind: np.ndarray  # (m,) FACE_A, FACE_B or EDGE
    face: np.ndarray  # (m,) the reference face (index into its own hull), -1 for EDGE
    depth: np.ndarray  # (m,) overlap along the axis (m); 0 where separated
    normal: np.ndarray  # (m, 3) unit, from A towards B (separated: the most separating axis)
    edge_a: np.ndarray  # (m,) A's edge of an edge contact, else -1
    edge_b: np.ndarray  # (m,) B's edge of an edge contact, else -1
    edge_point: np.ndarray  # (m, 3) midpoint of the edges' closest points (EDGE rows)
    scale: np.ndarray  # (m,) the pair's scale (m)


@parallel_jit
def _sat_rows_parallel(ta, ia, tb, ib, t, rot, out, start, stop, counts, blocks):
    """:func:`sat_rows` over the kernel threads, ``blocks`` blocks of rows, a scratch each."""
    n = stop - start
    for b in prange(blocks):
        work = sat_work(counts[0], counts[1], counts[2], counts[3])
        sat_rows(ta, ia, tb, ib, t, rot, out, 0, start + b * n // blocks,
                 start + (b + 1) * n // blocks, work, True)


@jit
def _sat_rows_serial(ta, ia, tb, ib, t, rot, out, start, stop, work):
    """:func:`sat_rows` in this thread, rows written at their own index."""
    sat_rows(ta, ia, tb, ib, t, rot, out, 0, start, stop, work, True)


def blocks_of(rows: int) -> int:
    """Blocks of rows of a parallel launch: a few per thread (rows differ in cost)."""
    return max(1, min(rows, 8 * numba.get_num_threads()))


def stacked(hulls: Hull | HullTable, index, m: int) -> tuple[HullTable, np.ndarray]:
    """(table, row index (m,)) of a hull (every row) or of a table and its rows' indices."""
    if isinstance(hulls, Hull):
        return stack_hulls((hulls,)), np.zeros(m, np.int64)
    return hulls, np.ascontiguousarray(index, np.int64)


def chunk_rows(table_a: HullTable, table_b: HullTable) -> int:
    """Rows per chunk of a call on these tables (:data:`CHUNK_ITEMS`)."""
    v, f, e, _ = work_counts(table_a, table_b)
    return max(1, CHUNK_ITEMS // (2 * (v + f + e)))


def run_rows(kernel, parallel_kernel, make_work, m: int, step: int, args: tuple,
             counts) -> None:
    """Rows 0..m of a row kernel (``kernel(*args, start, stop, work)``) in chunks of ``step``
    rows, the calling context's work limit checked between chunks: in this thread below
    :data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` rows (one ``make_work(*counts)``),
    else ``parallel_kernel(*args, start, stop, counts, blocks)`` over the kernel threads, one
    launch at a time."""
    if m < PARALLEL_MIN_ROWS:
        work = make_work(*counts) if m else None
        for start, stop in chunks(m, step):
            kernel(*args, start, stop, work)
        return
    counts = np.asarray(counts, np.int64)
    for start, stop in chunks(m, step):
        launch(parallel_kernel, *args, start, stop, counts, blocks_of(stop - start))


def choose_axis(hull_a: Hull | HullTable, hull_b: Hull | HullTable, t: np.ndarray,
                rot: np.ndarray, index_a=None, index_b=None) -> AxisChoice:
    """The contact axis of m rows (module docstring).

    Parameters
    ----------
    hull_a, hull_b : Hull or HullTable
        The parts, each in its body's frame: one hull for every row, or a table whose hull of
        row i is ``index_a[i]`` (``index_b[i]``).
    t : ndarray, shape (m, 3)
        B's body origin in A's body frame (metres).
    rot : ndarray, shape (m, 3, 3)
        B's body rotation in A's body frame.
    index_a, index_b : array_like of int, shape (m,), optional
        Each row's hull in a table.
    """
    m = len(t)
    ta, ia = stacked(hull_a, index_a, m)
    tb, ib = stacked(hull_b, index_b, m)
    out = axis_rows(m)
    args = (ta.arrays, ia, tb.arrays, ib, np.ascontiguousarray(t, np.float64),
            np.ascontiguousarray(rot, np.float64), out)
    run_rows(_sat_rows_serial, _sat_rows_parallel, sat_work, m, chunk_rows(ta, tb), args,
             work_counts(ta, tb))
    return AxisChoice(*out)
