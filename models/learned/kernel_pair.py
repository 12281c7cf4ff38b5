"""The learned predictors' row function, compiled: one pair's answer in ``single``,
``committee`` or ``auto``, the same function for one pair and for every row of a batch.

Per row (:func:`answer_row`), in the mode the caller picked for the row's pair:

* ``single`` (:func:`single_row`): the canonical frame
  (:mod:`~impactnet.models.learned.kernel_frame`), the pair's MLP
  (:mod:`~impactnet.models.learned.kernel_mlp`), the outputs back to the world;
* ``committee`` and ``auto`` (:func:`committee_row`): the exact labeller
  (:func:`impactnet.models.learned.region_label.label`, in the request's order), then the
  chain's decision: the canonical region of the contact (the labels mirrored into the bundle's
  order where the request is swapped, mapped by the symmetry fold), its committee's members,
  their mean and spread, and whether the exact solver takes the row: a region without a
  committee (both modes); in ``auto``, a clipped face-face contact
  (:data:`AUTO_EXACT_TYPES`) or an answer the pair's calibrated thresholds do not trust
  (:func:`unsure`);
* ``exact`` (an exact-only pair; in ``auto``, a pair without models) and every row handed on:
  the exact solver's own row function (:func:`impactnet.models.box.kernels.solve_row`), so the
  fallback is the exact answer to the last bit.

A pair's *program* is two read-only arrays (fewer arguments: a kernel's call costs about 50 ns
per array argument): ``values`` float64, the constants :data:`CONSTS` then the weights of the
pair's MLP pack, and ``index`` int64, a header (the numbers of layers, members and regions),
the pack's ``layers`` and ``members``, the committees' ``regions`` and the ``region_table``
(:class:`impactnet.models.learned.pair_runtime.PairRuntime` builds it, :func:`unpack` reads
it).

Outputs: the 12 `Contacts` arrays of :data:`impactnet.models.box.kernels.OUTPUTS` (request's
order; a learned contact's manifold is its point) and ``extras`` (4, n) float64, the rows
:data:`EXTRAS`: confidence, normal spread (deg), point spread (m), and 1.0 where the exact
solver answered (0.0: the learned path). Entries: :func:`answer_one` (one pair of six (w,)
vectors, the inputs checked in the kernel), :func:`answer_rows` / :func:`answer_rows_parallel`
(the rows ``index[start:stop]`` of checked inputs).
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.kernel_frame import maximum
from impactnet.models.box.kernel_inputs import as_rows, first_fault, vector
from impactnet.models.box.kernel_views import pair_frame
from impactnet.models.box.kernels import SCRATCH_SIZE, solve_row
from impactnet.models.compiled import jit, numba, parallel_jit
from impactnet.models.learned.canonical import FLIP_FEATURES, N_CONTACT_OUTPUTS, N_POSE_FEATURES
from impactnet.models.learned.kernel_frame import canonical, normal_to_world, point_to_world
from impactnet.models.learned.kernel_mlp import TILE_ROWS, forward, widest
from impactnet.models.learned.pair_dispatch import MIRROR_TYPE
from impactnet.models.learned.region_label import LABEL_FLOATS, LABEL_SMALL, label, scratch

#: Kernel modes (the mode a caller runs a pair's rows in).
EXACT, SINGLE, COMMITTEE, AUTO = 0, 1, 2, 3
#: Rows of ``extras``.
EXTRAS = ("confidence", "normal_spread", "point_spread", "exact")
CONFIDENCE, NORMAL_SPREAD, POINT_SPREAD, ANSWERED_EXACTLY = range(4)
#: A pair's constants (``consts``, float64), in this order: L and e (metres), the depth domain
#: (fractions of e), ``auto``'s confidence floor, normal spread limit (deg) and point spread
#: limit (metres).
CONSTS = ("scale", "edge", "depth_lo", "depth_hi", "confidence_min", "normal_spread_max",
          "point_spread_max")
SCALE, EDGE, DEPTH_LO, DEPTH_HI, CONFIDENCE_MIN, NORMAL_SPREAD_MAX, POINT_SPREAD_MAX = range(7)
#: Entries of a program's ``index`` before the pack's layers: the numbers of layers, members
#: (+ 1) and regions (+ 1).
HEADER = 3
#: Shape of the region table: type code, canonical feature of A + 1, of B + 1.
REGION_TABLE = (len(ct.CONTACT_TYPES), 27, 27)
#: Contact types whose experts ``auto`` never trusts where clipping matters (the labeller's
#: point is not exact): measured on stacking poses (a container set down flat on another with a
#: yaw of 0.5-2 degrees), the face-face experts' point errors reach 30-150 % of the shortest
#: edge while their spread stays small, so no calibrated threshold catches them; ``auto``
#: answers these rows exactly (about 4-9 % of the default scene's first contacts).
AUTO_EXACT_TYPES = (ct.FACE_FACE,)
#: Member normals shorter than this (dimensionless) count as their fallback direction in the
#: spread (see impactnet.models.learned.canonical.NORMAL_NORM_MIN).
_NORM_FLOOR = 1e-6
_DEGREES = 180.0 / math.pi


@jit
def unpack(values, index):
    """A program's arrays (module docstring): ``(weights, layers, members, regions,
    region_table, consts)``, views of ``values`` and ``index``."""
    n_layers, n_members, n_regions = index[0], index[1], index[2]
    at = HEADER + 4 * n_layers
    layers = index[HEADER:at].reshape((n_layers, 4))
    members, regions = index[at:at + n_members], index[at + n_members:at + n_members + n_regions]
    at += n_members + n_regions
    table = index[at:at + REGION_TABLE[0] * REGION_TABLE[1] * REGION_TABLE[2]].reshape(
        REGION_TABLE)
    return values[len(CONSTS):], layers, members, regions, table, values[:len(CONSTS)]


@jit
def make_scratch(layers, regions):
    """Per-thread scratch of :func:`answer_row`, as views of two allocations: the exact
    solver's, the MLPs' (the features first,
    :func:`~impactnet.models.learned.kernel_mlp.forward`) and its width, the committee's member
    outputs and their mean, the labeller's
    (:func:`~impactnet.models.learned.region_label.scratch`)."""
    most = 1
    for r in range(regions.shape[0] - 1):
        most = max(most, regions[r + 1] - regions[r])
    width = max(widest(layers), N_POSE_FEATURES)
    mlp = SCRATCH_SIZE + 3 * width
    outputs = mlp + most * N_CONTACT_OUTPUTS
    mean = outputs + N_CONTACT_OUTPUTS
    floats = np.empty(mean + LABEL_FLOATS)
    return (floats[:SCRATCH_SIZE], floats[SCRATCH_SIZE:mlp], width,
            floats[mlp:outputs].reshape((most, N_CONTACT_OUTPUTS)), floats[outputs:mean],
            scratch(floats[mean:], np.empty(LABEL_SMALL, np.int8)))


@jit
def _inverse_norm(members, m):
    """1 / |normal| of member m's outputs (the norm floored at ``_NORM_FLOOR``)."""
    n0, n1, n2 = members[m, 3], members[m, 4], members[m, 5]
    return 1.0 / math.sqrt(max(n0 * n0 + n1 * n1 + n2 * n2, _NORM_FLOOR * _NORM_FLOOR))


@jit
def spread(members, k, scale):
    """(normal spread, point spread) of the first k member outputs ``members`` (K, 7): the
    largest angle between two members' normals (degrees) and the largest distance between
    their points (metres: the canonical points are / L, ``scale`` = L)."""
    chord2 = dist2 = 0.0
    for a in range(k):
        inv_a = _inverse_norm(members, a)
        for b in range(a + 1, k):
            inv_b = _inverse_norm(members, b)
            chord = dist = 0.0
            for j in range(3):
                dn = members[a, 3 + j] * inv_a - members[b, 3 + j] * inv_b
                dp = members[a, j] - members[b, j]
                chord, dist = chord + dn * dn, dist + dp * dp
            chord2, dist2 = max(chord2, chord), max(dist2, dist)
    angle = 2.0 * math.asin(min(math.sqrt(chord2) * 0.5, 1.0)) * _DEGREES
    return angle, math.sqrt(dist2) * scale


@jit
def unsure(consts, confidence, normal_spread, point_spread, colliding, inside):
    """Whether ``auto``'s thresholds distrust a learned answer: confidence below the floor, a
    spread above its limit, or a contact whose depth leaves the trained domain."""
    return (confidence < consts[CONFIDENCE_MIN] or normal_spread > consts[NORMAL_SPREAD_MAX]
            or point_spread > consts[POINT_SPREAD_MAX] or (colliding and not inside))


@jit
def _write(out, extras, i, colliding, normal, depth, point, code, features, axis, confidence,
           spreads):
    """A learned answer into row i: its manifold is its point (count 1), or empty."""
    (colliding_out, normal_out, depth_out, point_out, code_out, feature_a_out, feature_b_out,
     axis_out, points_out, depths_out, count_out, pressure_out) = out
    colliding_out[i], depth_out[i], code_out[i], axis_out[i] = colliding, depth, code, axis
    feature_a_out[i], feature_b_out[i] = features
    count_out[i], pressure_out[i] = (1 if colliding else 0), 0.0
    for c in range(3):
        normal_out[i, c], point_out[i, c] = normal[c], point[c]
        points_out[i, 0, c] = point[c] if colliding else 0.0
    depths_out[i, 0] = depth
    for m in range(1, ct.MAX_MANIFOLD_POINTS):
        depths_out[i, m] = 0.0
        for c in range(3):
            points_out[i, m, c] = 0.0
    extras[CONFIDENCE, i], extras[ANSWERED_EXACTLY, i] = confidence, 0.0
    extras[NORMAL_SPREAD, i], extras[POINT_SPREAD, i] = spreads


@jit
def _bundle_order(inputs, swapped):
    """The six inputs in the bundle's order (A and B exchanged where ``swapped``)."""
    if swapped:
        return (inputs[3], inputs[4], inputs[5], inputs[0], inputs[1], inputs[2])
    return inputs


@jit
def single_row(inputs, i, weights, layers, members, consts, swapped, out, extras, work):
    """``single`` for pair i: the pair's MLP (member 0) on the canonical features."""
    position, rot_a, frame = pair_frame(_bundle_order(inputs, swapped), i)
    h = work[1]
    signs = canonical(frame[2], frame[3], frame[4], consts[SCALE], h)[0]
    at = forward(weights, layers, members, 0, h, work[2])
    point = point_to_world(position, rot_a, signs, h, at, consts[SCALE])
    normal = normal_to_world(rot_a, signs, h, at)
    if swapped:  # the answer for (B, A): the normal from the request's A to its B
        normal = (-normal[0], -normal[1], -normal[2])
    depth = h[at + 6]  # a fraction of e
    inside = consts[DEPTH_LO] <= depth <= consts[DEPTH_HI]
    _write(out, extras, i, True, normal, maximum(depth * consts[EDGE], 0.0), point, ct.NONE,
           (-1, -1), -1, 1.0 if inside else 0.0, (0.0, 0.0))


@jit
def _committee(inputs, i, weights, layers, members, regions, region_table, consts, swapped,
               labels, work):
    """The committee's answer of a colliding row whose point is not exact: (point, normal
    spread, point spread), or None where the region has no committee."""
    code, feature_a, feature_b, unclipped = labels
    position, rot_a, frame = pair_frame(_bundle_order(inputs, swapped), i)
    h, outputs, mean = work[1], work[3], work[4]
    signs, _, flip_a, flip_b = canonical(frame[2], frame[3], frame[4], consts[SCALE], h)
    if swapped:  # the labels in the bundle's order
        code, feature_a, feature_b = MIRROR_TYPE[code], feature_b, feature_a
    region = region_table[code, FLIP_FEATURES[flip_a, feature_a] + 1,
                          FLIP_FEATURES[flip_b, feature_b] + 1]
    if region < 0:
        return None
    first, k = regions[region], regions[region + 1] - regions[region]
    for j in range(N_CONTACT_OUTPUTS):
        mean[j] = 0.0
    for m in range(k):  # the features stay in h[:12]: each member starts from them
        at = forward(weights, layers, members, first + m, h, work[2])
        for j in range(N_CONTACT_OUTPUTS):
            outputs[m, j] = h[at + j]
            mean[j] += h[at + j]
    for j in range(N_CONTACT_OUTPUTS):
        mean[j] /= k
    spreads = spread(outputs, k, consts[SCALE])
    return point_to_world(unclipped, rot_a, signs, mean, 0, consts[SCALE]), spreads


@jit
def committee_row(inputs, i, weights, layers, members, regions, region_table, consts, mode,
                  swapped, out, extras, work):
    """``committee`` or ``auto`` for pair i (module docstring); True where the exact solver is
    to answer it (nothing written then)."""
    hit, axis, depth, normal, code, feature_a, feature_b, exact_point, point = label(
        inputs, i, work[5])
    inside = consts[DEPTH_LO] <= depth / consts[EDGE] <= consts[DEPTH_HI]
    confidence = 1.0 if (inside or not hit) else 0.0
    spreads = (0.0, 0.0)
    if not hit:  # separated: the centres' midpoint, as the exact solver answers
        pa, pb = vector(inputs[1], i), vector(inputs[4], i)
        point = (0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2]))
    elif not exact_point:  # the experts' residual from the unclipped point
        if mode == AUTO and code in AUTO_EXACT_TYPES:
            return True
        answer = _committee(inputs, i, weights, layers, members, regions, region_table, consts,
                            swapped, (code, feature_a, feature_b, point), work)
        if answer is None:
            return True
        point, spreads = answer
    if mode == AUTO and unsure(consts, confidence, spreads[0], spreads[1], hit, inside):
        return True
    _write(out, extras, i, hit, normal, depth, point, code, (feature_a, feature_b), axis,
           confidence, spreads)
    return False


@jit
def answer_row(inputs, i, weights, layers, members, regions, region_table, consts, mode,
               swapped, out, extras, work):
    """Pair i of ``inputs`` (six checked (k, w) float64 arrays, k 1 or n, in the request's
    order) in ``mode`` (:data:`EXACT`, :data:`SINGLE`, :data:`COMMITTEE`, :data:`AUTO`) with the
    pair's program (:class:`impactnet.models.learned.pair_runtime.PairRuntime`), solved in the
    bundle's order where ``swapped``; into row i of ``out`` and ``extras``."""
    exact = mode == EXACT
    if mode == SINGLE:
        single_row(inputs, i, weights, layers, members, consts, swapped, out, extras, work)
    elif not exact:
        exact = committee_row(inputs, i, weights, layers, members, regions, region_table,
                              consts, mode, swapped, out, extras, work)
    if exact:
        solve_row(inputs[0], inputs[1], inputs[2], inputs[3], inputs[4], inputs[5], i, work[0],
                  out)
        extras[CONFIDENCE, i], extras[ANSWERED_EXACTLY, i] = 1.0, 1.0
        extras[NORMAL_SPREAD, i], extras[POINT_SPREAD, i] = 0.0, 0.0


@jit
def answer_rows(inputs, index, values, program, mode, swapped, out, extras, start, stop):
    """The pairs ``index[start:stop]`` (int64 row numbers) serially (:func:`answer_row`), with
    the pair's program (``values``, ``program``: module docstring)."""
    weights, layers, members, regions, table, consts = unpack(values, program)
    work = make_scratch(layers, regions)
    for e in range(start, stop):
        answer_row(inputs, index[e], weights, layers, members, regions, table, consts, mode,
                   swapped, out, extras, work)


@parallel_jit
def answer_rows_parallel(inputs, index, values, program, mode, swapped, out, extras, start,
                         stop):
    """:func:`answer_rows` over the kernel threads, a tile of rows at a time (launch it with
    :func:`impactnet.models.compiled.launch`)."""
    weights, layers, members, regions, table, consts = unpack(values, program)
    tiles = (stop - start + TILE_ROWS - 1) // TILE_ROWS
    for tile in numba.prange(tiles):
        work = make_scratch(layers, regions)
        for e in range(start + tile * TILE_ROWS, min(stop, start + (tile + 1) * TILE_ROWS)):
            answer_row(inputs, index[e], weights, layers, members, regions, table, consts,
                       mode, swapped, out, extras, work)


@jit
def answer_one(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, values,
               program, mode, swapped, colliding, normal, depth, point, contact_type_code,
               feature_a, feature_b, axis, manifold_points, manifold_depths, manifold_count,
               pressure, extras):
    """One pair of six (w,) float64 vectors: the inputs checked (returns the first fault,
    :func:`~impactnet.models.box.kernel_inputs.first_fault`, nothing written), then
    :func:`answer_row` into the one-row outputs; returns 0."""
    fault = first_fault(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b, 1)
    if fault == 0:
        inputs = (as_rows(size_a), as_rows(position_a), as_rows(quaternion_a), as_rows(size_b),
                  as_rows(position_b), as_rows(quaternion_b))
        out = (colliding, normal, depth, point, contact_type_code, feature_a, feature_b, axis,
               manifold_points, manifold_depths, manifold_count, pressure)
        weights, layers, members, regions, table, consts = unpack(values, program)
        answer_row(inputs, 0, weights, layers, members, regions, table, consts, mode, swapped,
                   out, extras, make_scratch(layers, regions))
    return fault
