"""The convex solver's contact of one row (stages 2 and 3 of
:func:`~impactnet.models.compound.convex_contact.contact_rows`): the face contact of the reference
face the separating-axis test chose (:func:`~impactnet.models.compound.convex_face.face_region`, in
the reference hull's frame, mapped back to A's), an edge contact's closest points, a separated row's
midpoint, and
the answer mapped to the world. Each mapping sums as the NumPy solver summed (its bits)."""
from __future__ import annotations

from impactnet.models import contacts as ct
from impactnet.models.box.tolerances import FACE_INC_CODES, FACE_REF_CODES
from impactnet.models.compiled import jit
from impactnet.models.compound.convex_face import face_region
from impactnet.models.compound.sat_faces import turn
from impactnet.models.compound.sat_walk import EDGE, FACE_A


@jit
def _turned(rot, k, x0, x1, x2):
    """``R x`` (``R = rot[k]``) summed as NumPy's einsum sums a C-contiguous row
    (``(r0 x0 + r2 x2) + r1 x1``): the mappings back to A's frame and to the world keep the
    NumPy solver's bits."""
    return ((rot[k, 0, 0] * x0 + rot[k, 0, 2] * x2) + rot[k, 0, 1] * x1,
            (rot[k, 1, 0] * x0 + rot[k, 1, 2] * x2) + rot[k, 1, 1] * x1,
            (rot[k, 2, 0] * x0 + rot[k, 2, 2] * x2) + rot[k, 2, 1] * x1)


@jit
def tables_of(tab):
    """A table's arrays that the contact stage reads, once per call: (reference: face
    normals, offsets, frames, starts, loop starts, side planes; incident: vertex, face, edge
    starts, loop starts and vertices, the faces of each vertex (starts, faces), the adjacency
    (starts, vertices, edges); vertices; face normals; centres)."""
    return ((tab.face_normals, tab.face_offsets, tab.face_frames, tab.face_start,
             tab.loop_start, tab.side_planes),
            (tab.vertex_start, tab.face_start, tab.edge_start, tab.loop_start, tab.loop_vertex,
             tab.vertex_face_start, tab.vertex_face, tab.adjacency_start, tab.adjacency_vertex,
             tab.adjacency_edge), tab.vertices, tab.face_normals, tab.centre)


@jit
def _region(ref, hr, face, inc, hi, x_inc, normals_inc, depth, scale, work):
    """:func:`~impactnet.models.compound.convex_face.face_region` of reference hull ``hr``
    (its face ``face``; ``ref`` its table's reference arrays, :func:`_tables`) and incident
    hull ``hi`` (``inc``: its table's incident arrays; its vertices and normals in the
    reference frame)."""
    normals, offsets, frames, face_start, loop_start, planes = ref
    (vertex_start, inc_faces, edge_start, inc_loops, loop_vertex, vertex_face_start,
     vertex_face, adjacency_start, adjacency_vertex, adjacency_edge) = inc
    return face_region(normals, offsets, frames, face_start, loop_start, planes, hr, face,
                       vertex_start, inc_faces, edge_start, inc_loops, loop_vertex,
                       vertex_face_start, vertex_face, adjacency_start, adjacency_vertex,
                       adjacency_edge, hi, x_inc, normals_inc, depth, scale, work)


@jit
def _face_of_a(tables_a, ha, tables_b, hb, t, rot, k, face, depth, scale, work):
    """A's face is the reference, B incident (placed as the separating-axis test placed it):
    (point, depth, pressure, code, feature_a, feature_b, manifold count), A's frame."""
    ref_a, _, _, _, _ = tables_a
    _, inc_b, vertices_b, normals_b, _ = tables_b
    vstart_b, fstart_b = inc_b[0], inc_b[1]
    vb0, fb0 = vstart_b[hb], fstart_b[hb]
    turn(vertices_b, vb0, vstart_b[hb + 1] - vb0, rot, k, t, True, 1.0, work.sat.y)
    turn(normals_b, fb0, fstart_b[hb + 1] - fb0, rot, k, t, False, 1.0, work.sat.normals_b)
    point, depth, pressure, feature, rank, count = _region(
        ref_a, ha, face, inc_b, hb, work.sat.y, work.sat.normals_b, depth, scale, work.face)
    return point, depth, pressure, FACE_REF_CODES[rank], face, feature, count


@jit
def _face_of_b(tables_a, ha, tables_b, hb, t, rot, k, face, depth, scale, manifold_out,
               work):
    """B's face is the reference: A in B's frame (``R^T v - R^T t`` and ``R^T n``), the answer
    and the manifold (into ``manifold_out[k]``) back to A's frame: (point, depth, pressure,
    code, feature_a, feature_b, manifold count)."""
    _, inc_a, vertices, normals, _ = tables_a
    ref_b, _, _, _, _ = tables_b
    x_inc, normals_inc, manifold = work.face.x_inc, work.face.normals_inc, work.face.manifold
    tt = (rot[k, 0, 0] * t[k, 0] + rot[k, 1, 0] * t[k, 1] + rot[k, 2, 0] * t[k, 2],
          rot[k, 0, 1] * t[k, 0] + rot[k, 1, 1] * t[k, 1] + rot[k, 2, 1] * t[k, 2],
          rot[k, 0, 2] * t[k, 0] + rot[k, 1, 2] * t[k, 1] + rot[k, 2, 2] * t[k, 2])
    va0, fa0 = inc_a[0][ha], inc_a[1][ha]
    for v in range(inc_a[0][ha + 1] - va0):
        x0, x1, x2 = vertices[va0 + v, 0], vertices[va0 + v, 1], vertices[va0 + v, 2]
        for i in range(3):
            x_inc[v, i] = (rot[k, 0, i] * x0 + rot[k, 1, i] * x1 + rot[k, 2, i] * x2) - tt[i]
    for g in range(inc_a[1][ha + 1] - fa0):
        x0, x1, x2 = normals[fa0 + g, 0], normals[fa0 + g, 1], normals[fa0 + g, 2]
        for i in range(3):
            normals_inc[g, i] = rot[k, 0, i] * x0 + rot[k, 1, i] * x1 + rot[k, 2, i] * x2
    point, depth, pressure, feature, rank, count = _region(
        ref_b, hb, face, inc_a, ha, x_inc, normals_inc, depth, scale, work.face)
    point = _turned(rot, k, point[0], point[1], point[2])
    point = (point[0] + t[k, 0], point[1] + t[k, 1], point[2] + t[k, 2])
    for j in range(count):
        turned = _turned(rot, k, manifold[j, 0], manifold[j, 1], manifold[j, 2])
        for c in range(3):
            manifold_out[k, j, c] = turned[c] + t[k, c]
    return point, depth, pressure, FACE_INC_CODES[rank], feature, face, count


@jit
def _separated(tables_a, ha, tables_b, hb, t, rot, k, point_out):
    """A separated row's point: the midpoint of the hulls' centres."""
    centre_a, centre_b = tables_a[4], tables_b[4]
    for c in range(3):
        b = t[k, c] + (rot[k, c, 0] * centre_b[hb, 0] + rot[k, c, 1] * centre_b[hb, 1]
                       + rot[k, c, 2] * centre_b[hb, 2])
        point_out[k, c] = 0.5 * (centre_a[ha, c] + b)


@jit
def row_contact(tables_a, ha, tables_b, hb, t, rot, axis, row, out, k, work):
    """Stage 2: the contact of row k, A's frame, into ``out`` (a separated row: the midpoint
    of the hulls' centres, no features, an empty manifold)."""
    colliding, kind, face, depth = (axis.colliding[row], axis.kind[row], axis.face[row],
                                    axis.depth[row])
    out.colliding[k], out.depth[k], out.pressure[k] = colliding, 0.0, 0.0
    out.contact_type_code[k], out.manifold_count[k] = 0, 0
    out.feature_a[k], out.feature_b[k] = -1, -1
    out.manifold_points[k] = 0.0
    out.manifold_depths[k] = 0.0
    for c in range(3):
        out.normal[k, c] = axis.normal[row, c]
    if not colliding:
        _separated(tables_a, ha, tables_b, hb, t, rot, k, out.point)
        return
    if kind == EDGE:  # the midpoint of the edges' closest points, edge ids
        faces_a, faces_b = tables_a[1][1], tables_b[1][1]
        out.depth[k], out.contact_type_code[k], out.manifold_count[k] = depth, ct.EDGE_EDGE, 1
        out.feature_a[k] = faces_a[ha + 1] - faces_a[ha] + axis.edge_a[row]
        out.feature_b[k] = faces_b[hb + 1] - faces_b[hb] + axis.edge_b[row]
        out.manifold_depths[k, 0] = depth
        for c in range(3):
            out.point[k, c] = axis.edge_point[row, c]
            out.manifold_points[k, 0, c] = axis.edge_point[row, c]
        return
    scale = axis.scale[row]
    if kind == FACE_A:
        point, depth, pressure, code, feature_a, feature_b, count = _face_of_a(
            tables_a, ha, tables_b, hb, t, rot, k, face, depth, scale, work)
        for j in range(count):
            for c in range(3):
                out.manifold_points[k, j, c] = work.face.manifold[j, c]
    else:
        point, depth, pressure, code, feature_a, feature_b, count = _face_of_b(
            tables_a, ha, tables_b, hb, t, rot, k, face, depth, scale, out.manifold_points,
            work)
    out.contact_type_code[k], out.feature_a[k], out.feature_b[k] = code, feature_a, feature_b
    for c in range(3):
        out.point[k, c] = point[c]
    out.depth[k], out.pressure[k], out.manifold_count[k] = depth, pressure, count
    for j in range(count):
        out.manifold_depths[k, j] = work.face.manifold_depth[j]


@jit
def to_world(position_a, rot_a, out, k):
    """Stage 3: row k to the world: normal R_A n, point and manifold points R_A x + p_A."""
    normal = _turned(rot_a, k, out.normal[k, 0], out.normal[k, 1], out.normal[k, 2])
    point = _turned(rot_a, k, out.point[k, 0], out.point[k, 1], out.point[k, 2])
    for c in range(3):
        out.normal[k, c] = normal[c]
        out.point[k, c] = point[c] + position_a[k, c]
    manifold = out.manifold_points
    for j in range(out.manifold_count[k]):
        turned = _turned(rot_a, k, manifold[k, j, 0], manifold[k, j, 1], manifold[k, j, 2])
        for c in range(3):
            manifold[k, j, c] = turned[c] + position_a[k, c]
