"""The compiled compound pipeline over the kernel threads, and the touching test.

Each parallel kernel splits rows start..stop into ``blocks`` blocks of poses (a few per thread:
poses differ in cost), each block unpacking the sets and allocating its scratch once
(:mod:`impactnet.models.compound.kernel_pipeline`); launch them with
:func:`impactnet.models.compiled.launch`. A pose's answer does not depend on its block, so a
batch answers each pose as one call of that pose alone.

:func:`touching_rows`: whether any candidate part pair of a pose touches, by the convex
solver's separating-axis test on every part's hull (box parts through their box hulls), the
candidates in the broadphase's order, stopping at the first that touches; no contact geometry,
no filter (:func:`impactnet.models.compound.oracle.compound_touching`).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compiled import jit, numba, parallel_jit
from impactnet.models.compound.convex_sat import axis_rows, sat_rows
from impactnet.models.compound.kernel_broadphase import pose_candidates, relative
from impactnet.models.compound.kernel_frame import pose_frame
from impactnet.models.compound.kernel_narrowphase import convex_inputs_for, convex_row
from impactnet.models.compound.kernel_pipeline import (
    bodies_of,
    count_rows,
    fill_rows,
    scratch_for,
    solve_block,
    unpacked,
)

prange = numba.prange


@jit
def _block(start, stop, blocks, b):
    """Rows of block b of ``blocks`` over start..stop."""
    n = stop - start
    return start + b * n // blocks, start + (b + 1) * n // blocks


@parallel_jit
def count_parallel(ra, ia, fa, rb, ib, fb, index_a, index_b, pa, qa, pb, qb, counts, start,
                   stop, blocks):
    """:func:`~impactnet.models.compound.kernel_pipeline.count_rows` over the kernel threads
    (A's three buffers, B's, the bodies' indices, the poses: every tuple is built inside the
    loop, numba's parallel loops take arrays only)."""
    for b in prange(blocks):
        tables = unpacked(ra, ia, fa, rb, ib, fb)
        lo, hi = _block(start, stop, blocks, b)
        count_rows(tables, index_a, index_b, (pa, qa, pb, qb), counts, lo, hi,
                   scratch_for(tables)[0])


@parallel_jit
def fill_parallel(ra, ia, fa, rb, ib, fb, index_a, index_b, pa, qa, pb, qb, offsets, cand_a,
                  cand_b, start, stop, blocks):
    """:func:`~impactnet.models.compound.kernel_pipeline.fill_rows` over the kernel threads."""
    for b in prange(blocks):
        tables = unpacked(ra, ia, fa, rb, ib, fb)
        lo, hi = _block(start, stop, blocks, b)
        fill_rows(tables, index_a, index_b, (pa, qa, pb, qb), offsets, cand_a, cand_b, lo, hi,
                  scratch_for(tables)[0])


@parallel_jit
def solve_parallel(ra, ia, fa, rb, ib, fb, index_a, index_b, pa, qa, pb, qb, offsets, cand_a,
                   cand_b, o0, o1, o2, o3, o4, o5, o6, o7, o8, o9, o10, o11, hull_a, hull_b, t,
                   rot, position_a, rot_a, kept_rows, kept, s0, s1, s2, s3, s4, start, stop,
                   blocks):
    """:func:`~impactnet.models.compound.kernel_pipeline.solve_block` over the kernel threads
    (the candidate outputs ``o0..o11``, the convex inputs, the summary's ``s0..s4`` as
    arrays)."""
    for b in prange(blocks):
        tables = unpacked(ra, ia, fa, rb, ib, fb)
        lo, hi = _block(start, stop, blocks, b)
        rows = ((o0, o1, o2, o3, o4, o5, o6, o7, o8, o9, o10, o11),
                (hull_a, hull_b, t, rot, position_a, rot_a))
        solve_block(tables, index_a, index_b, (pa, qa, pb, qb), (offsets, cand_a, cand_b), rows,
                    kept_rows, kept, (s0, s1, s2, s3, s4), lo, hi, scratch_for(tables))


@jit
def _touches(tables, a, b, frame, scratch, found, axis):
    """Whether any candidate of one pose touches (module docstring)."""
    body_a, hulls_a, body_b, hulls_b = tables
    broad, _, work = scratch
    cand_a, cand_b, inputs = found
    count = pose_candidates(body_a, a, body_b, b, relative(frame[1], frame[5], frame[3]), broad,
                            cand_a, cand_b, 0, True)
    base_a, base_b = body_a.body_part[a], body_b.body_part[b]
    hull_a, hull_b, t, rot = inputs[0], inputs[1], inputs[2], inputs[3]
    for c in range(count):
        convex_row(base_a + cand_a[c], base_b + cand_b[c], frame, inputs, c)
        sat_rows(hulls_a, hull_a, hulls_b, hull_b, t, rot, axis, c, c, c + 1, work.sat, False)
        if axis.colliding[0]:
            return True
    return False


@jit
def touching_rows(tables, index_a, index_b, poses, touching, start, stop, scratch):
    """``touching[p]`` for poses start..stop (module docstring)."""
    body_a, _, body_b, _ = tables
    position_a, quaternion_a, position_b, quaternion_b = poses
    wa, wb = body_a.widest, body_b.widest
    most = wa[0] * wb[0]
    found = (np.empty(most, np.int64), np.empty(most, np.int64), convex_inputs_for(most))
    axis = axis_rows(1)
    for p in range(start, stop):
        a, b = bodies_of(index_a, index_b, p)
        frame = pose_frame(position_a, quaternion_a, position_b, quaternion_b, p)
        touching[p] = _touches(tables, a, b, frame, scratch, found, axis)


@jit
def touching_serial(buffers, index_a, index_b, poses, touching, start, stop):
    """:func:`touching_rows` in this thread."""
    tables = unpacked(buffers[0], buffers[1], buffers[2], buffers[3], buffers[4], buffers[5])
    touching_rows(tables, index_a, index_b, poses, touching, start, stop, scratch_for(tables))


@parallel_jit
def touching_parallel(ra, ia, fa, rb, ib, fb, index_a, index_b, pa, qa, pb, qb, touching, start,
                      stop, blocks):
    """:func:`touching_rows` over the kernel threads."""
    for b in prange(blocks):
        tables = unpacked(ra, ia, fa, rb, ib, fb)
        lo, hi = _block(start, stop, blocks, b)
        touching_rows(tables, index_a, index_b, (pa, qa, pb, qb), touching, lo, hi,
                      scratch_for(tables))


@jit
def count_serial(buffers, index_a, index_b, poses, counts, start, stop):
    """:func:`~impactnet.models.compound.kernel_pipeline.count_rows` in this thread."""
    tables = unpacked(buffers[0], buffers[1], buffers[2], buffers[3], buffers[4], buffers[5])
    count_rows(tables, index_a, index_b, poses, counts, start, stop, scratch_for(tables)[0])


@jit
def fill_serial(buffers, index_a, index_b, poses, offsets, cand_a, cand_b, start, stop):
    """:func:`~impactnet.models.compound.kernel_pipeline.fill_rows` in this thread."""
    tables = unpacked(buffers[0], buffers[1], buffers[2], buffers[3], buffers[4], buffers[5])
    fill_rows(tables, index_a, index_b, poses, offsets, cand_a, cand_b, start, stop,
              scratch_for(tables)[0])


@jit
def matrix_candidates(buffers, offset, rot_a, rot_b):
    """(pose, part_a, part_b) of the candidates of n poses given by ``p_B - p_A`` (n, 3) and the
    rotation matrices (n, 3, 3) of the two bodies (each the first body of its set)."""
    tables = unpacked(buffers[0], buffers[1], buffers[2], buffers[3], buffers[4], buffers[5])
    body_a, _, body_b, _ = tables
    broad = scratch_for(tables)[0]
    n = offset.shape[0]
    offsets = np.zeros(n + 1, np.int64)
    empty = np.empty(0, np.int64)
    for write in (False, True):
        size = offsets[n]
        pose, cand_a, cand_b = (np.empty(size, np.int64), np.empty(size, np.int64),
                                np.empty(size, np.int64))
        for p in range(n):
            frame = relative(_matrix(rot_a, p), _matrix(rot_b, p),
                             (offset[p, 0], offset[p, 1], offset[p, 2]))
            if write:
                count = pose_candidates(body_a, 0, body_b, 0, frame, broad, cand_a, cand_b,
                                        offsets[p], True)
                pose[offsets[p]:offsets[p] + count] = p
            else:
                offsets[p + 1] = offsets[p] + pose_candidates(body_a, 0, body_b, 0, frame,
                                                              broad, empty, empty, 0, False)
    return pose, cand_a, cand_b


@jit
def _matrix(rot, p):
    """Rotation p of (n, 3, 3) matrices as a row-major 9-tuple."""
    return (rot[p, 0, 0], rot[p, 0, 1], rot[p, 0, 2], rot[p, 1, 0], rot[p, 1, 1], rot[p, 1, 2],
            rot[p, 2, 0], rot[p, 2, 1], rot[p, 2, 2])
