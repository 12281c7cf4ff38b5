"""The exact solver's intermediate stages for other callers, as serial kernels over rows.

The same row functions as the solver (:mod:`impactnet.models.box.kernels`), stopped early:

* :func:`unit_rows`, :func:`unit_pair`: the unit quaternions the solver uses;
* :func:`relative_rows`: stage 1, B in A's frame (the learned predictors' canonical frame);
* :func:`decision_rows`: stage 2 and the face contact's labels, without the clip and the
  centre of pressure (the committee's region labeller,
  :mod:`impactnet.models.learned.region_label`): the decision, the contact type and features, the
  edge-edge point, and the incident face as seen from the reference face;
* :func:`reference_rows`: points given in a face contact's reference coordinates, in the world;
* :func:`axis_rows`: the 15 overlaps and unit axes of the separating-axis test (tests);
* :func:`matrix_rows`: the whole solver on pairs whose orientations are given as matrices.

Inputs are the solver's: six float64 (k, w) arrays with k 1 (broadcast) or n, checked
(:func:`impactnet.models.box.kernel_inputs.first_fault`), quaternions not necessarily unit.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.kernel_face import (
    cyclic,
    from_reference,
    incident_feature,
    incident_quad,
    reference_view,
)
from impactnet.models.box.kernel_frame import local_frame, matvec, moved, rotation_of
from impactnet.models.box.kernel_inputs import first_fault, pick, unit_quaternion, vector
from impactnet.models.box.kernel_sat import SAT_SCRATCH, decide, overlaps, unit_axis
from impactnet.models.box.kernels import SCRATCH_SIZE, solve_pair
from impactnet.models.box.tolerances import FACE_INC_CODES, FACE_REF_CODES, SNAP_TOL_REL
from impactnet.models.compiled import jit
from impactnet.models.geometry.box_features import NO_FEATURE


@jit
def unit_rows(quaternion, out):
    """The rows of ``quaternion`` (k, 4) as unit quaternions into ``out`` (k, 4)."""
    for i in range(quaternion.shape[0]):
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = unit_quaternion(quaternion, i)


@jit
def unit_pair(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, out):
    """The first fault of one pair of (1, w) inputs
    (:func:`impactnet.models.box.kernel_inputs.first_fault`), and where there is none, its two
    unit quaternions into ``out`` (2, 4)."""
    fault = first_fault(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, 1)
    if fault == 0:
        out[0, 0], out[0, 1], out[0, 2], out[0, 3] = unit_quaternion(quaternion_a, 0)
        out[1, 0], out[1, 1], out[1, 2], out[1, 3] = unit_quaternion(quaternion_b, 0)
    return fault


@jit
def pair_frame(inputs, i):
    """Pair i of the six inputs: A's position and rotation, and its stage 1
    (:func:`impactnet.models.box.kernel_frame.local_frame`)."""
    size_a, position_a, quaternion_a, size_b, position_b, quaternion_b = inputs
    qa, qb = unit_quaternion(quaternion_a, i), unit_quaternion(quaternion_b, i)
    rot_a = rotation_of(qa[0], qa[1], qa[2], qa[3])
    pa = vector(position_a, i)
    return pa, rot_a, local_frame(vector(size_a, i), pa, rot_a, vector(size_b, i),
                                  vector(position_b, i), rotation_of(qb[0], qb[1], qb[2], qb[3]))


@jit
def relative_rows(inputs, half_a, half_b, rotation, translation):
    """Stage 1 of n pairs: half-extents (n, 3) metres, ``R = R_A^T R_B`` (n, 3, 3) and
    ``t = R_A^T (p_B - p_A)`` (n, 3) metres."""
    for i in range(half_a.shape[0]):
        ha, hb, r, t, _, _ = pair_frame(inputs, i)[2]
        for c in range(3):
            half_a[i, c], half_b[i, c], translation[i, c] = ha[c], hb[c], t[c]
            for j in range(3):
                rotation[i, c, j] = r[3 * c + j]


@jit
def decision_rows(inputs, colliding, axis, depth, normal, code, feature_a, feature_b, point,
                  quad, reference, scale):
    """The solver's decision and labels of n pairs, without the clip (module docstring).

    Outputs (n rows each): ``colliding`` bool; ``axis`` int8 (0-14); ``depth`` (metres, the
    overlap along the axis: the solver's depth except where a face contact's incident box
    hangs beyond the reference face); ``normal`` (3,) world, unit, A towards B; ``code``,
    ``feature_a``, ``feature_b`` int8 (the contact type and features); ``point`` (3,) world
    (metres): an edge-edge contact's point, else A's centre; ``quad`` (4, 3): a face contact's
    incident face vertices in cyclic order, reference coordinates (axis, u, w) (metres, zeros
    elsewhere); ``reference`` (4,): the reference face's half-extents (along the axis, u, w;
    metres) and side (+-1) (zeros elsewhere); ``scale``: the pair scale (metres).
    """
    work = np.empty(SAT_SCRATCH)
    for i in range(colliding.shape[0]):
        pa, rot_a, frame = pair_frame(inputs, i)
        ha, hb, r, t, tb, pair_scale = frame
        hit, chosen, overlap, n_a, edge, at, edge_a, edge_b = decide(ha, hb, r, t, tb,
                                                                     pair_scale, work)
        colliding[i], axis[i], depth[i], scale[i] = hit, chosen, overlap, pair_scale
        n_w, p_w = matvec(rot_a, n_a), moved(pa, rot_a, at)
        code[i], feature_a[i], feature_b[i] = (ct.EDGE_EDGE if edge else ct.NONE,
                                               edge_a, edge_b)
        for c in range(4):
            reference[i, c] = 0.0
            for x in range(3):
                quad[i, c, x] = 0.0
        if hit and not edge:
            h_ref, h_inc, rot_ri, t_ri = reference_view(ha, hb, r, t, tb, chosen)
            ref_axis = chosen % 3
            vertices, ref_sign, k, side = incident_quad(h_inc, rot_ri, t_ri, ref_axis)
            height, half_u, half_w = cyclic(h_ref, ref_axis)
            depths = (height - ref_sign * vertices[0][0], height - ref_sign * vertices[1][0],
                      height - ref_sign * vertices[2][0], height - ref_sign * vertices[3][0])
            incident, rank = incident_feature(depths, k, side, SNAP_TOL_REL * pair_scale)
            ref_face = 2 * ref_axis + int(ref_sign < 0)
            flip = chosen >= 3
            code[i] = FACE_INC_CODES[rank] if flip else FACE_REF_CODES[rank]
            feature_a[i], feature_b[i] = (incident, ref_face) if flip else (ref_face, incident)
            reference[i, 0], reference[i, 1], reference[i, 2] = height, half_u, half_w
            reference[i, 3] = ref_sign
            for c in range(4):
                for x in range(3):
                    quad[i, c, x] = vertices[c][x]
        elif not hit:
            feature_a[i], feature_b[i] = NO_FEATURE, NO_FEATURE
        for c in range(3):
            normal[i, c], point[i, c] = n_w[c], p_w[c]


@jit
def reference_rows(inputs, rows, axis, points, out):
    """Points of face contacts given in reference coordinates (axis, u, w) (metres), in the
    world frame: ``points`` (m, 3) of pairs ``rows`` (m,) whose contact axis is ``axis`` (m,)
    (0-5), into ``out`` (m, 3); mapped as the solver maps its impact point."""
    for e in range(rows.shape[0]):
        pa, rot_a, frame = pair_frame(inputs, rows[e])
        r, t = frame[2], frame[3]
        ref_axis = axis[e] % 3
        p = from_reference(ref_axis, points[e, 0], points[e, 1], points[e, 2])
        if axis[e] >= 3:
            p = moved(t, r, p)
        world = moved(pa, rot_a, p)
        for c in range(3):
            out[e, c] = world[c]


@jit
def axis_rows(inputs, overlap, units, scale):
    """The separating-axis test's table of n pairs: ``overlap`` (n, 15) (metres, +inf for a
    skipped cross axis), ``units`` (n, 15, 3) the unit axes in A's frame (not oriented; a
    skipped cross axis gives a finite, meaningless vector) and ``scale`` (n,) (metres)."""
    work = np.empty(SAT_SCRATCH)
    for i in range(overlap.shape[0]):
        ha, hb, r, t, tb, pair_scale = pair_frame(inputs, i)[2]
        overlaps(ha, hb, r, t, tb, pair_scale, work)
        scale[i] = pair_scale
        for a in range(15):
            overlap[i, a] = work[a]
            unit = unit_axis(r, t, tb, a)[0]
            for c in range(3):
                units[i, a, c] = unit[c]



@jit
def _matrix(rotation, i):
    """Row i (broadcast) of (k, 3, 3) rotations as a row-major 9-tuple."""
    r = pick(rotation, i)
    return (rotation[r, 0, 0], rotation[r, 0, 1], rotation[r, 0, 2], rotation[r, 1, 0],
            rotation[r, 1, 1], rotation[r, 1, 2], rotation[r, 2, 0], rotation[r, 2, 1],
            rotation[r, 2, 2])


@jit
def matrix_rows(inputs, rotation_a, rotation_b, out):
    """The solver (:func:`impactnet.models.box.kernels.solve_pair`) on n pairs whose
    orientations are the matrices ``rotation_a``, ``rotation_b`` (k, 3, 3), k 1 or n, used as
    given (a reflection solves the mirrored pair); the quaternions of ``inputs`` are unused.
    ``out``: the 12 output arrays (:data:`impactnet.models.box.kernels.OUTPUTS`)."""
    size_a, position_a, _, size_b, position_b, _ = inputs
    work = np.empty(SCRATCH_SIZE)
    for i in range(out[2].shape[0]):
        solve_pair(vector(size_a, i), vector(position_a, i), _matrix(rotation_a, i),
                   vector(size_b, i), vector(position_b, i), _matrix(rotation_b, i), work,
                   out, i)
