"""Stage 2 of the compiled compound pipeline: the exact contact of every candidate part pair
of a block of poses, written at the candidate's own row.

* Box part pairs go through the box solver's row function
  (:func:`impactnet.models.box.kernels.solve_pair`), about A's origin as the NumPy oracle
  solved them (a body at the position limit has parts beyond it, and the box solver's domain
  is the body's): the parts' centres ``R c`` (``np.einsum``'s order), the rotations of the
  quaternions normalised once more (the box solver's own normalisation), then the point and
  the manifold moved back by ``p_A``.
* Pairs with a convex part go through the convex solver's range function
  (:func:`impactnet.models.compound.convex_contact.contact_rows`) once per block, box rows
  skipped, separated rows stopped at their first separating axis: each row's pose ``t``,
  ``R`` as the NumPy oracle computed them (``np.einsum`` over a transposed view, a fused
  ``np.matmul``).

The conventions hold for every part contact (normal from A's part towards B's, the centre of
pressure as the point, docs/design.md); features are the box ids for box parts, hull ids for convex
ones; ``axis`` is the box solver's for box pairs, -1 for the others.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.kernels import SCRATCH_SIZE, solve_pair
from impactnet.models.compiled import jit
from impactnet.models.compound.convex_contact import ContactRows, contact_rows
from impactnet.models.compound.kernel_frame import fused_product, pair_rows, plain_columns

#: The candidate rows' output arrays, in :data:`impactnet.models.box.kernels.OUTPUTS`' order
#: with int32 features: (name, trailing shape, dtype).
OUTPUTS = (("colliding", (), np.bool_), ("normal", (3,), np.float64),
           ("depth", (), np.float64), ("point", (3,), np.float64),
           ("contact_type_code", (), np.int8), ("feature_a", (), np.int32),
           ("feature_b", (), np.int32), ("axis", (), np.int8),
           ("manifold_points", (ct.MAX_MANIFOLD_POINTS, 3), np.float64),
           ("manifold_depths", (ct.MAX_MANIFOLD_POINTS,), np.float64),
           ("manifold_count", (), np.int8), ("pressure", (), np.float64))


@jit
def rows_for(m):
    """Output arrays of m candidate rows (:data:`OUTPUTS`, uninitialised)."""
    return (np.empty(m, np.bool_), np.empty((m, 3)), np.empty(m), np.empty((m, 3)),
            np.empty(m, np.int8), np.empty(m, np.int32), np.empty(m, np.int32),
            np.empty(m, np.int8), np.empty((m, ct.MAX_MANIFOLD_POINTS, 3)),
            np.empty((m, ct.MAX_MANIFOLD_POINTS)), np.empty(m, np.int8), np.empty(m))


@jit
def convex_inputs_for(m):
    """The convex rows' inputs for m candidate rows: hull of A, of B (-1: a box pair), B's
    origin and rotation in A's frame, A's origin and rotation (``contact_rows``' arguments)."""
    return (np.full(m, -1, np.int64), np.full(m, -1, np.int64), np.empty((m, 3)),
            np.empty((m, 3, 3)), np.empty((m, 3)), np.empty((m, 3, 3)))


@jit
def box_work():
    """The box solver's scratch (:data:`~impactnet.models.box.kernels.SCRATCH_SIZE`)."""
    return np.empty(SCRATCH_SIZE)


@jit
def _vector(array, k):
    """Row k of an (m, 3) array as a 3-tuple."""
    return array[k, 0], array[k, 1], array[k, 2]


@jit
def box_row(body_a, i, body_b, j, frame, out, c, work):
    """Box parts i and j (set numbering) of one pose (``frame``:
    :func:`~impactnet.models.compound.kernel_frame.pose_frame`) into candidate row c."""
    p_a, rot_a, rot_a2, offset, _, rot_b, rot_b2 = frame
    ca = body_a.part_centre
    cb = body_b.part_centre
    centre_a = pair_rows(rot_a, ca[i, 0], ca[i, 1], ca[i, 2])
    turned = pair_rows(rot_b, cb[j, 0], cb[j, 1], cb[j, 2])
    centre_b = (offset[0] + turned[0], offset[1] + turned[1], offset[2] + turned[2])
    solve_pair(_vector(body_a.part_size, i), centre_a, rot_a2, _vector(body_b.part_size, j),
               centre_b, rot_b2, work, out, c)
    point, points = out[3], out[8]
    for k in range(3):
        point[c, k] = point[c, k] + p_a[k]
    for m in range(out[10][c]):
        for k in range(3):
            points[c, m, k] = points[c, m, k] + p_a[k]


@jit
def convex_row(i, j, frame, inputs, c):
    """A pair with a convex part (hulls i of A's table, j of B's) into the convex inputs' row
    c: B's pose in A's frame as the NumPy oracle computed it."""
    hull_a, hull_b, t, rot, position_a, rot_a = inputs
    p_a, r_a, _, offset, _, r_b, _ = frame
    hull_a[c], hull_b[c] = i, j
    moved = plain_columns(r_a, offset[0], offset[1], offset[2])
    rel = fused_product(r_a, r_b)
    for k in range(3):
        t[c, k], position_a[c, k] = moved[k], p_a[k]
        for m in range(3):
            rot[c, k, m], rot_a[c, k, m] = rel[3 * k + m], r_a[3 * k + m]


@jit
def convex_rows(hulls_a, hulls_b, inputs, out, start, stop, work):
    """Every convex row of candidate rows start..stop (box rows skipped), separated rows
    stopped early; their ``axis`` is -1. Rows that are all box rows cost nothing (the
    convex solver's set-up, ~3 us, is skipped: a pose of box parts at N = 1)."""
    hull_a, hull_b, t, rot, position_a, rot_a = inputs
    convex = False
    for c in range(start, stop):
        if hull_a[c] >= 0:
            convex = True
            break
    if not convex:
        return
    (colliding, normal, depth, point, code, feature_a, feature_b, axis, manifold_points,
     manifold_depths, manifold_count, pressure) = out
    rows = ContactRows(colliding, normal, depth, point, code, feature_a, feature_b,
                       manifold_points, manifold_depths, manifold_count, pressure)
    contact_rows(hulls_a, hull_a, hulls_b, hull_b, t, rot, position_a, rot_a, rows, start, stop,
                 work, False)
    for c in range(start, stop):
        if hull_a[c] >= 0:
            axis[c] = -1
