"""Stage 3 of the compiled compound pipeline: the covered-surface filter of one part contact.

A part contact is dropped when the surface it touches is one its body covers with its other
parts (a container's roof under its own top castings): all of its manifold points, moved from
the mid-surface back onto A's part (half their depth along the normal) lie inside other parts
of A, or all of them moved onto B's part (half their depth the other way) inside other parts
of B, deeper than :data:`~impactnet.models.compound.flat_tables.INSIDE_MARGIN_REL` of the
other part's smallest extent (``margin``). Only the parts whose bounds overlap the own part's
can hold its points (``partner``): box parts are tested by their bounds, convex parts by their
face planes (after their bounds). A contact without manifold points stays.

The sums are the NumPy oracle's: the point in the body's frame ``R^T (x - p)`` in order (an
``np.einsum`` over a transposed index), a face's plane value ``n . x - h`` fused (an
``np.matmul`` of several points; one point alone went through ``gemv_t`` there, a 1-ulp
difference that matters only on a margin's edge).
"""
from __future__ import annotations

from impactnet.models.compiled import jit
from impactnet.models.compound.kernel_frame import fused, plain_columns


@jit
def _inside_partner(local, other, body, hulls):
    """Whether a point (its body's frame, 3-tuple) lies inside part ``other`` (set numbering)
    by more than that part's margin."""
    size, centre, margin = body.part_size, body.part_centre, body.margin[other]
    near = True
    deep = True
    for k in range(3):
        gap = abs(local[k] - centre[other, k])
        half = 0.5 * size[other, k]
        near = near and gap < half
        deep = deep and gap < half - margin
    if body.is_box[other]:
        return deep
    if not near:
        return False
    normals, offsets = hulls.face_normals, hulls.face_offsets
    top = -1.0e308
    first = True
    for f in range(hulls.face_start[other], hulls.face_start[other + 1]):
        value = fused(local[0], local[1], local[2], normals[f, 0], normals[f, 1],
                      normals[f, 2]) - offsets[f]
        if first or value > top:
            top, first = value, False
    return top < -margin


@jit
def _covered(point, position, rot, own, body, hulls):
    """Whether a world point lies inside a part of the body (origin ``position``, rotation
    ``rot``: 3- and 9-tuples) other than ``own``."""
    local = plain_columns(rot, point[0] - position[0], point[1] - position[1],
                          point[2] - position[2])
    for s in range(body.partner_start[own], body.partner_start[own + 1]):
        if _inside_partner(local, body.partner[s], body, hulls):
            return True
    return False


@jit
def hidden(out, c, i, j, frame, body_a, hulls_a, body_b, hulls_b):
    """Whether candidate row c (parts i of A, j of B, set numbering; a touching row) lies on a
    surface its body covers (module docstring)."""
    p_a, rot_a, _, _, p_b, rot_b, _ = frame
    normal, points, depths = out[1], out[8], out[9]
    count = out[10][c]
    if count == 0:
        return False
    covered_a = covered_b = True
    for m in range(count):
        half = (0.5 * depths[c, m] * normal[c, 0], 0.5 * depths[c, m] * normal[c, 1],
                0.5 * depths[c, m] * normal[c, 2])
        x = (points[c, m, 0], points[c, m, 1], points[c, m, 2])
        if covered_a:
            covered_a = _covered((x[0] + half[0], x[1] + half[1], x[2] + half[2]), p_a, rot_a,
                                 i, body_a, hulls_a)
        if covered_b:
            covered_b = _covered((x[0] - half[0], x[1] - half[1], x[2] - half[2]), p_b, rot_b,
                                 j, body_b, hulls_b)
        if not (covered_a or covered_b):
            return False
    return covered_a or covered_b
