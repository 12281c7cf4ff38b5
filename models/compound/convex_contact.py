"""The exact contact of two convex parts, compiled: :func:`contact_rows` solves a range of rows
(each one pair of hulls at one relative pose; one row: ``stop = start + 1``), the kernel other
kernels call (the compound oracle's narrowphase); :func:`convex_contacts` answers m poses of
the same two hulls, :func:`stacked_contacts` m rows naming their hulls in two
:class:`~impactnet.models.compound.hull_stack.HullTable` (a row's answer is the same bits
either way: alone or in a batch, in one thread or several).

The convex counterpart of :func:`impactnet.models.box.exact.box_box`, with its conventions
(DESIGN.md): the separating-axis test and tie rule of
:mod:`impactnet.models.compound.convex_sat`, the centre of pressure of
:mod:`impactnet.models.compound.convex_face` for face axes, the midpoint of the edges' closest
points for edge axes. Works in A's body frame (``t = R_A^T (p_B - p_A)``, ``R = R_A^T R_B``,
:func:`relative_poses`), so far from the origin the answer is the same as at it, and maps the
answer to the world.

Answers are :class:`impactnet.models.contacts.Contacts` rows, with two differences from the box
solver's: ``feature_a``/``feature_b`` are hull feature ids (:mod:`impactnet.models.compound.hull`,
int32: a 256-sided twistlock has 1,538 features), and ``axis`` is -1 (a hull has no fixed axis
numbering). A box part's hull keeps the box's feature ids.

The rows run stage by stage (the separating-axis test of every row of the range, then every
row's contact): a kernel reads a table's arrays out of their tuple once per call, not once per
row, since each read costs a reference count that the kernel threads would contend for.
:func:`stacked_contacts` runs the rows in chunks (:func:`impactnet.models.compiled.chunks`), in
the caller's thread below :data:`~impactnet.models.compiled.PARALLEL_MIN_ROWS` rows, else over
the kernel threads (:func:`impactnet.models.compiled.launch`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.tolerances import FACE_INC_CODES, FACE_REF_CODES
from impactnet.models.compiled import jit, on_warm_up, parallel_jit
from impactnet.models.compound.convex_face import FaceWork, face_region, face_work
from impactnet.models.compound.convex_sat import (
    EDGE,
    FACE_A,
    SatWork,
    axis_rows,
    choose_axis,
    chunk_rows,
    prange,
    run_rows,
    sat_rows,
    sat_work,
    stacked,
    turn,
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
def _turned(rot, k, x0, x1, x2):
    """``R x`` (``R = rot[k]``) summed as NumPy's einsum sums a C-contiguous row
    (``(r0 x0 + r2 x2) + r1 x1``): the mappings back to A's frame and to the world keep the
    NumPy solver's bits."""
    return ((rot[k, 0, 0] * x0 + rot[k, 0, 2] * x2) + rot[k, 0, 1] * x1,
            (rot[k, 1, 0] * x0 + rot[k, 1, 2] * x2) + rot[k, 1, 1] * x1,
            (rot[k, 2, 0] * x0 + rot[k, 2, 2] * x2) + rot[k, 2, 1] * x1)


@jit
def _face_tables(tab):
    """The arrays of a table that the contact stage reads: vertices, face normals, offsets and
    frames, vertex, face and edge starts, loops (starts, vertices, side planes), the faces of
    each vertex (starts, faces), the adjacency (starts, vertices, edges)."""
    return (tab.vertices, tab.face_normals, tab.face_offsets, tab.face_frames, tab.vertex_start,
            tab.face_start, tab.edge_start, tab.loop_start, tab.loop_vertex, tab.side_planes,
            tab.vertex_face_start, tab.vertex_face, tab.adjacency_start, tab.adjacency_vertex,
            tab.adjacency_edge)


@jit
def contact_rows(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start, stop, work):
    """The contacts of rows start..stop (module docstring), written to ``out`` at their own
    index, world frame.

    Parameters
    ----------
    ta, tb : HullArrays
        The tables' arrays (:attr:`HullTable.arrays`) of A's and B's hulls.
    ia, ib : ndarray of int64, shape (m,)
        Each row's hulls in the tables.
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
    """
    # Stage 1: the separating-axis test of every row (convex_sat.sat_rows).
    axis = axis_rows(stop - start)
    sat_rows(ta, ia, tb, ib, t, rot, axis, start, start, stop, work.sat)
    # The tables' arrays, once per call.
    (vertices_a, normals_a, offsets_a, frames_a, vstart_a, fstart_a, estart_a, loops_a,
     loop_vertex_a, planes_a, vface_start_a, vface_a, adjacency_start_a, adjacency_vertex_a,
     adjacency_edge_a) = _face_tables(ta)
    (vertices_b, normals_b0, offsets_b, frames_b, vstart_b, fstart_b, estart_b, loops_b,
     loop_vertex_b, planes_b, vface_start_b, vface_b, adjacency_start_b, adjacency_vertex_b,
     adjacency_edge_b) = _face_tables(tb)
    centre_a, centre_b = ta.centre, tb.centre
    y, normals_b = work.sat.y, work.sat.normals_b
    face_work = work.face
    x_inc, normals_inc, manifold, manifold_depth = (face_work.x_inc, face_work.normals_inc,
                                                    face_work.manifold, face_work.manifold_depth)
    colliding_in, kind_in, face_in, depth_in = axis.colliding, axis.kind, axis.face, axis.depth
    normal_in, edge_a_in, edge_b_in, point_in, scale_in = (axis.normal, axis.edge_a, axis.edge_b,
                                                           axis.edge_point, axis.scale)
    normals_out, points_out, depths_out = out.normal, out.point, out.depth
    codes_out, features_a, features_b = out.contact_type_code, out.feature_a, out.feature_b
    manifold_out, manifold_depths_out = out.manifold_points, out.manifold_depths
    counts_out, pressures_out, colliding_out = out.manifold_count, out.pressure, out.colliding
    for k in range(start, stop):
        row = k - start
        ha, hb = ia[k], ib[k]
        # Stage 2: the contact of the row, A's frame (a separated row: the midpoint of the
        # hulls' centres, no features, an empty manifold).
        colliding, kind, face, depth = (colliding_in[row], kind_in[row], face_in[row],
                                        depth_in[row])
        colliding_out[k], depths_out[k], pressures_out[k] = colliding, 0.0, 0.0
        codes_out[k], counts_out[k], features_a[k], features_b[k] = 0, 0, -1, -1
        manifold_out[k] = 0.0
        manifold_depths_out[k] = 0.0
        for c in range(3):
            normals_out[k, c] = normal_in[row, c]
        if not colliding:
            for c in range(3):
                b = t[k, c] + (rot[k, c, 0] * centre_b[hb, 0] + rot[k, c, 1] * centre_b[hb, 1]
                               + rot[k, c, 2] * centre_b[hb, 2])
                points_out[k, c] = 0.5 * (centre_a[ha, c] + b)
        elif kind == EDGE:  # the midpoint of the edges' closest points, edge ids
            depths_out[k], codes_out[k], counts_out[k] = depth, ct.EDGE_EDGE, 1
            features_a[k] = fstart_a[ha + 1] - fstart_a[ha] + edge_a_in[row]
            features_b[k] = fstart_b[hb + 1] - fstart_b[hb] + edge_b_in[row]
            manifold_depths_out[k, 0] = depth
            for c in range(3):
                points_out[k, c] = point_in[row, c]
                manifold_out[k, 0, c] = point_in[row, c]
        else:
            if kind == FACE_A:  # A's face, B incident (B placed as the separating-axis test)
                vb0, fb0 = vstart_b[hb], fstart_b[hb]
                turn(vertices_b, vb0, vstart_b[hb + 1] - vb0, rot, k, t, True, 1.0, y)
                turn(normals_b0, fb0, fstart_b[hb + 1] - fb0, rot, k, t, False, 1.0, normals_b)
                point, depth, pressure, feature, rank, count = face_region(
                    normals_a, offsets_a, frames_a, fstart_a, loops_a, planes_a, ha, face,
                    vstart_b, fstart_b, estart_b, loops_b, loop_vertex_b, vface_start_b, vface_b,
                    adjacency_start_b, adjacency_vertex_b, adjacency_edge_b, hb, y, normals_b,
                    depth, scale_in[row], face_work)
                codes_out[k] = FACE_REF_CODES[rank]
                features_a[k], features_b[k] = face, feature
                for j in range(count):
                    for c in range(3):
                        manifold_out[k, j, c] = manifold[j, c]
            else:  # B's face: A in B's frame, R^T v - R^T t and R^T n; the answer back to A's
                tt = (rot[k, 0, 0] * t[k, 0] + rot[k, 1, 0] * t[k, 1] + rot[k, 2, 0] * t[k, 2],
                      rot[k, 0, 1] * t[k, 0] + rot[k, 1, 1] * t[k, 1] + rot[k, 2, 1] * t[k, 2],
                      rot[k, 0, 2] * t[k, 0] + rot[k, 1, 2] * t[k, 1] + rot[k, 2, 2] * t[k, 2])
                va0, fa0 = vstart_a[ha], fstart_a[ha]
                for v in range(vstart_a[ha + 1] - va0):
                    x0, x1, x2 = (vertices_a[va0 + v, 0], vertices_a[va0 + v, 1],
                                  vertices_a[va0 + v, 2])
                    for i in range(3):
                        x_inc[v, i] = (rot[k, 0, i] * x0 + rot[k, 1, i] * x1
                                       + rot[k, 2, i] * x2) - tt[i]
                for g in range(fstart_a[ha + 1] - fa0):
                    x0, x1, x2 = normals_a[fa0 + g, 0], normals_a[fa0 + g, 1], normals_a[fa0 + g, 2]
                    for i in range(3):
                        normals_inc[g, i] = (rot[k, 0, i] * x0 + rot[k, 1, i] * x1
                                             + rot[k, 2, i] * x2)
                point, depth, pressure, feature, rank, count = face_region(
                    normals_b0, offsets_b, frames_b, fstart_b, loops_b, planes_b, hb, face,
                    vstart_a, fstart_a, estart_a, loops_a, loop_vertex_a, vface_start_a, vface_a,
                    adjacency_start_a, adjacency_vertex_a, adjacency_edge_a, ha, x_inc,
                    normals_inc, depth, scale_in[row], face_work)
                point = _turned(rot, k, point[0], point[1], point[2])
                point = (point[0] + t[k, 0], point[1] + t[k, 1], point[2] + t[k, 2])
                codes_out[k] = FACE_INC_CODES[rank]
                features_a[k], features_b[k] = feature, face
                for j in range(count):
                    turned = _turned(rot, k, manifold[j, 0], manifold[j, 1], manifold[j, 2])
                    for c in range(3):
                        manifold_out[k, j, c] = turned[c] + t[k, c]
            for c in range(3):
                points_out[k, c] = point[c]
            depths_out[k], pressures_out[k], counts_out[k] = depth, pressure, count
            for j in range(count):
                manifold_depths_out[k, j] = manifold_depth[j]
        # Stage 3: to the world: normal R_A n, point and manifold points R_A x + p_A.
        normal = _turned(rot_a, k, normals_out[k, 0], normals_out[k, 1], normals_out[k, 2])
        point = _turned(rot_a, k, points_out[k, 0], points_out[k, 1], points_out[k, 2])
        for c in range(3):
            normals_out[k, c] = normal[c]
            points_out[k, c] = point[c] + position_a[k, c]
        for j in range(counts_out[k]):
            turned = _turned(rot_a, k, manifold_out[k, j, 0], manifold_out[k, j, 1],
                             manifold_out[k, j, 2])
            for c in range(3):
                manifold_out[k, j, c] = turned[c] + position_a[k, c]


@parallel_jit
def _contact_rows_parallel(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start, stop, sizes,
                           blocks):
    """:func:`contact_rows` over the kernel threads, ``blocks`` blocks of rows, a scratch
    each."""
    n = stop - start
    for b in prange(blocks):
        work = make_work(sizes[0], sizes[1], sizes[2], sizes[3], sizes[4])
        contact_rows(ta, ia, tb, ib, t, rot, position_a, rot_a, out, start + b * n // blocks,
                     start + (b + 1) * n // blocks, work)


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
    run_rows(contact_rows, _contact_rows_parallel, make_work, m, chunk_rows(ta, tb), args,
             work_sizes(ta, tb))
    return Contacts(colliding=out.colliding, normal=out.normal, depth=out.depth,
                    point=out.point, contact_type_code=out.contact_type_code,
                    feature_a=out.feature_a, feature_b=out.feature_b,
                    axis=np.full(m, -1, np.int8), manifold_points=out.manifold_points,
                    manifold_depths=out.manifold_depths, manifold_count=out.manifold_count,
                    pressure=out.pressure)


@on_warm_up
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
