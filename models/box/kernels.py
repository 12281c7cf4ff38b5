"""The exact box-box solver as compiled kernels: one row function, the same for one pair and a
million.

Stages of one pair (one module each, scalar code over one row, MuJoCo's collider style):

0. :mod:`~impactnet.models.box.kernel_inputs`: the input checks and the unit quaternions;
1. :mod:`~impactnet.models.box.kernel_frame`: the pair in A's frame;
2. :mod:`~impactnet.models.box.kernel_sat`: the separating-axis test and its tie rule;
3. :mod:`~impactnet.models.box.kernel_face`: the face manifold (incident face clipped against the
   reference face) and the contact's features;
4. :mod:`~impactnet.models.box.kernel_pressure`: the impact point, the centre of pressure of the
   footprint, and the region's depth; then everything back to the world frame
   (:func:`solve_pair`).

Entries (:mod:`impactnet.models.compiled` compiles them, caches their machine code and launches
the parallel one):

* :func:`solve_pair`: one validated pair into row ``row`` of the output arrays; the function
  other kernels call (the compound oracle's, for its box part pairs);
* :func:`solve_checked`: checks every pair
  (:func:`~impactnet.models.box.kernel_inputs.first_fault`), then solves them all, serially: N = 1
  (one-dimensional inputs) and small batches, in one call;
* :func:`solve_rows` / :func:`solve_rows_parallel`: the rows ``start:stop`` of checked inputs,
  serially / over the kernel threads (``prange`` over tiles of :data:`TILE_ROWS` rows, one
  scratch array per tile);
* :func:`solve_one`: :func:`solve_checked` for one pair of six vectors, the simulator's call,
  in a dispatcher of its own that is closed once compiled (:func:`one_pair_entry`): input of
  another type is refused there, never compiled for.

:mod:`impactnet.models.box.warm_up` compiles or loads them all, and the views of
:mod:`impactnet.models.box.kernel_views`.

The outputs are the `Contacts` arrays of :data:`OUTPUTS`, in that order, each C-contiguous
with its field's dtype; rows past the manifold's count are zero.
"""
from __future__ import annotations

import threading

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.kernel_face import (
    SURVIVORS,
    face_manifold,
    from_reference,
    reference_view,
)
from impactnet.models.box.kernel_frame import local_frame, matvec, maximum, moved, rotation_of
from impactnet.models.box.kernel_inputs import (
    as_rows,
    fault_code,
    first_fault,
    unit_quaternion,
    vector,
)
from impactnet.models.box.kernel_pressure import PRESSURE_SCRATCH, centre_of_pressure
from impactnet.models.box.kernel_sat import decide
from impactnet.models.box.tolerances import FACE_INC_CODES, FACE_REF_CODES, REGION_DEPTH_TOL_REL
from impactnet.models.compiled import jit, numba, parallel_jit

#: The output arrays of the entries, in their order: `Contacts` fields with (shape, dtype).
OUTPUTS = (("colliding", (), np.bool_), ("normal", (3,), np.float64),
           ("depth", (), np.float64), ("point", (3,), np.float64),
           ("contact_type_code", (), np.int8), ("feature_a", (), np.int8),
           ("feature_b", (), np.int8), ("axis", (), np.int8),
           ("manifold_points", (ct.MAX_MANIFOLD_POINTS, 3), np.float64),
           ("manifold_depths", (ct.MAX_MANIFOLD_POINTS,), np.float64),
           ("manifold_count", (), np.int8), ("pressure", (), np.float64))
#: Scratch slots (float64) of the manifold in the world frame: x, y, z and depth per point.
MANIFOLD = PRESSURE_SCRATCH
#: Scratch slots the solver uses in all: a caller of :func:`solve_pair` passes this many.
SCRATCH_SIZE = MANIFOLD + 4 * ct.MAX_MANIFOLD_POINTS
#: Rows per tile of the parallel kernel: one scratch allocation per tile.
TILE_ROWS = 64
#: Fault kind of output arrays that do not fit (:func:`solve_checked`).
OUTPUT_SHAPE = 7


@jit
def _face_contact(position_a, rot_a, frame, axis, depth, work):
    """Stages 3-4 of a face-axis contact: the manifold (world frame, into ``work`` at
    :data:`MANIFOLD`: x, y, z and depth per point), the impact point (A's frame) and the depth
    (module docstring of :mod:`~impactnet.models.box.kernel_pressure`); returns
    ``(point, depth, count, code, feature_a, feature_b, pressure)``."""
    ha, hb, r, t, tb, scale = frame
    ref_axis, flip = axis % 3, axis >= 3
    h_ref, h_inc, rot_ri, t_ri = reference_view(ha, hb, r, t, tb, axis)
    count, ref_sign, incident, rank, deepest = face_manifold(h_ref, h_inc, rot_ri, t_ri,
                                                             ref_axis, scale, work)
    height = h_ref[ref_axis]
    for m in range(count):
        at = SURVIVORS + 4 * m
        d = maximum(work[at + 2], 0.0)
        p = from_reference(ref_axis, ref_sign * height - ref_sign * 0.5 * d, work[at],
                           work[at + 1])
        world = moved(position_a, rot_a, moved(t, r, p) if flip else p)
        at = MANIFOLD + 4 * m
        work[at], work[at + 1], work[at + 2], work[at + 3] = world[0], world[1], world[2], d
    centre, region_depth, pressure = centre_of_pressure(h_ref, h_inc, rot_ri, t_ri, ref_axis,
                                                        scale, deepest, work)
    point = from_reference(ref_axis, centre[0], centre[1], centre[2])
    if flip:  # the reference frame is B's: to A's
        point = moved(t, r, point)
    if region_depth >= 0.0 and region_depth < depth - REGION_DEPTH_TOL_REL * scale:
        depth = region_depth  # the incident box hangs beyond the reference face
    ref_face = 2 * ref_axis + int(ref_sign < 0)
    if flip:
        return point, depth, count, FACE_INC_CODES[rank], incident, ref_face, pressure
    return point, depth, count, FACE_REF_CODES[rank], ref_face, incident, pressure


@jit
def solve_pair(size_a, position_a, rot_a, size_b, position_b, rot_b, work, out, row):
    """Solve one validated box pair into row ``row`` of the output arrays.

    Parameters
    ----------
    size_a, size_b : 3-tuple of float
        Full edge lengths (metres), within :mod:`impactnet.models.domain`.
    position_a, position_b : 3-tuple of float
        Centres in the world frame (metres).
    rot_a, rot_b : 9-tuple of float
        Rotations, row-major (``v_world = R v_body``); from a unit quaternion:
        :func:`impactnet.models.box.kernel_frame.rotation_of`.
    work : ndarray of float64, shape (>= SCRATCH_SIZE,)
        Scratch, one per thread.
    out : tuple of ndarray
        The 12 output arrays of :data:`OUTPUTS` (n rows each).
    row : int
        The row to write.
    """
    # Stage 1: B in A's frame, so that the answer does not depend on where the pair is.
    frame = local_frame(size_a, position_a, rot_a, size_b, position_b, rot_b)
    ha, hb, r, t, tb, scale = frame
    # Stage 2: the contact axis by the separating-axis test and its tie rule; an edge-edge
    # contact's point and edges come with it.
    colliding, axis, depth, normal, edge, point, feature_a, feature_b = decide(
        ha, hb, r, t, tb, scale, work)
    # Stages 3-4: a face contact's manifold, features, impact point and depth; the point and
    # the manifold in the world frame (A's rotation and position).
    count, code, pressure = 0, ct.NONE, 0.0
    if not colliding:  # the centres' midpoint
        point = (0.5 * (position_a[0] + position_b[0]), 0.5 * (position_a[1] + position_b[1]),
                 0.5 * (position_a[2] + position_b[2]))
    elif edge:  # one point, the edges' closest points' midpoint
        point = moved(position_a, rot_a, point)
        count, code = 1, ct.EDGE_EDGE
        work[MANIFOLD], work[MANIFOLD + 1], work[MANIFOLD + 2] = point[0], point[1], point[2]
        work[MANIFOLD + 3] = depth
    else:
        point, depth, count, code, feature_a, feature_b, pressure = _face_contact(
            position_a, rot_a, frame, axis, depth, work)
        point = moved(position_a, rot_a, point)
    # The row's answer, manifold slots past its count zeroed.
    world_normal = matvec(rot_a, normal)
    (colliding_out, normal_out, depth_out, point_out, code_out, feature_a_out, feature_b_out,
     axis_out, points_out, depths_out, count_out, pressure_out) = out
    colliding_out[row], depth_out[row], axis_out[row] = colliding, depth, axis
    code_out[row], feature_a_out[row], feature_b_out[row] = code, feature_a, feature_b
    count_out[row], pressure_out[row] = count, pressure
    for c in range(3):
        normal_out[row, c], point_out[row, c] = world_normal[c], point[c]
    for m in range(ct.MAX_MANIFOLD_POINTS):
        at = MANIFOLD + 4 * m
        for c in range(3):
            points_out[row, m, c] = work[at + c] if m < count else 0.0
        depths_out[row, m] = work[at + 3] if m < count else 0.0


@jit
def solve_row(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, i, work,
              out):
    """Pair i of the six (k, w) input arrays (broadcast rows; quaternions normalised here)
    into row i of ``out``."""
    qa, qb = unit_quaternion(quaternion_a, i), unit_quaternion(quaternion_b, i)
    solve_pair(vector(size_a, i), vector(position_a, i), rotation_of(qa[0], qa[1], qa[2], qa[3]),
               vector(size_b, i), vector(position_b, i), rotation_of(qb[0], qb[1], qb[2], qb[3]),
               work, out, i)


@jit
def solve_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, colliding,
               normal, depth, point, contact_type_code, feature_a, feature_b, axis,
               manifold_points, manifold_depths, manifold_count, pressure, start, stop):
    """Pairs ``start:stop`` of checked inputs, serially (module docstring); inputs (k, w) or
    (w,) float64, outputs :data:`OUTPUTS`."""
    out = (colliding, normal, depth, point, contact_type_code, feature_a, feature_b, axis,
           manifold_points, manifold_depths, manifold_count, pressure)
    sa, pa, qa = as_rows(size_a), as_rows(position_a), as_rows(quaternion_a)
    sb, pb, qb = as_rows(size_b), as_rows(position_b), as_rows(quaternion_b)
    work = np.empty(SCRATCH_SIZE)
    for i in range(start, stop):
        solve_row(sa, pa, qa, sb, pb, qb, i, work, out)


@parallel_jit
def solve_rows_parallel(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                        colliding, normal, depth, point, contact_type_code, feature_a,
                        feature_b, axis, manifold_points, manifold_depths, manifold_count,
                        pressure, start, stop):
    """:func:`solve_rows` over the kernel threads, a tile of :data:`TILE_ROWS` rows at a time
    (launch it with :func:`impactnet.models.compiled.launch`)."""
    out = (colliding, normal, depth, point, contact_type_code, feature_a, feature_b, axis,
           manifold_points, manifold_depths, manifold_count, pressure)
    tiles = (stop - start + TILE_ROWS - 1) // TILE_ROWS
    for tile in numba.prange(tiles):
        work = np.empty(SCRATCH_SIZE)
        for i in range(start + tile * TILE_ROWS, min(stop, start + (tile + 1) * TILE_ROWS)):
            solve_row(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, i,
                      work, out)


@jit
def _fits(out, n):
    """Whether the 12 output arrays (:data:`OUTPUTS`) hold n rows of their fields' shapes."""
    m = ct.MAX_MANIFOLD_POINTS
    fits = out[1].shape == (n, 3) and out[3].shape == (n, 3)
    fits = fits and out[8].shape == (n, m, 3) and out[9].shape == (n, m)
    fits = fits and out[0].shape[0] == n and out[2].shape[0] == n and out[4].shape[0] == n
    fits = fits and out[5].shape[0] == n and out[6].shape[0] == n and out[7].shape[0] == n
    return fits and out[10].shape[0] == n and out[11].shape[0] == n


@jit
def solve_checked(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                  colliding, normal, depth, point, contact_type_code, feature_a, feature_b,
                  axis, manifold_points, manifold_depths, manifold_count, pressure, n):
    """Check the inputs of ``n`` pairs, then solve them all serially; returns 0, or the first
    fault (:func:`~impactnet.models.box.kernel_inputs.first_fault`) with nothing solved.
    Inputs (k, w) float64 with k 1 or n, or (w,) each for one pair (widths checked here)."""
    fault = first_fault(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, n)
    out = (colliding, normal, depth, point, contact_type_code, feature_a, feature_b, axis,
           manifold_points, manifold_depths, manifold_count, pressure)
    if fault == 0 and not _fits(out, n):
        fault = fault_code(OUTPUT_SHAPE, 0, 0)
    if fault == 0:
        solve_rows(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                   colliding, normal, depth, point, contact_type_code, feature_a, feature_b,
                   axis, manifold_points, manifold_depths, manifold_count, pressure, 0, n)
    return fault


@jit
def solve_one(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, colliding,
              normal, depth, point, contact_type_code, feature_a, feature_b, axis,
              manifold_points, manifold_depths, manifold_count, pressure):
    """:func:`solve_checked` of one pair of (w,) float64 vectors: its own dispatcher, closed
    to any other argument types once compiled (:func:`one_pair_entry`)."""
    return solve_checked(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                         colliding, normal, depth, point, contact_type_code, feature_a,
                         feature_b, axis, manifold_points, manifold_depths, manifold_count,
                         pressure, 1)


def output_arrays(n: int) -> list[np.ndarray]:
    """Fresh output arrays of n rows (:data:`OUTPUTS`; uninitialised: the kernels write every
    entry)."""
    return [np.empty((n, *shape), dtype) for _, shape, dtype in OUTPUTS]


def example_pair() -> list[np.ndarray]:
    """The six inputs of one touching pair of cubes, as (w,) float64 vectors."""
    return [np.array(v, np.float64) for v in ([1.0, 1.0, 1.0], [0.0, 0.0, 0.0],
                                              [1.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0],
                                              [0.2, 0.1, 0.99], [1.0, 0.0, 0.0, 0.0])]


_CLOSING = threading.Lock()
_closed = False


def one_pair_entry():
    """:func:`solve_one`, compiled (or loaded) for (w,) float64 C-contiguous vectors and
    writable outputs, then closed: another argument type raises TypeError instead of
    compiling a variant (the callers turn such input into the batch path's arrays)."""
    global _closed
    if not _closed:
        with _CLOSING:
            if not _closed:
                solve_one(*example_pair(), *output_arrays(1))
                solve_one.disable_compile()
                _closed = True
    return solve_one
