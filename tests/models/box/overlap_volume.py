"""Test helper: docs/design.md's centre of pressure of a face contact, by exact polyhedral
integration.

Not a test module, and independent of the solver: NumPy and SciPy's convex hull only, nothing
from ``models`` (no manifold, no clipping, no pressure code).

The rule (docs/design.md): the contact region is the footprint on the reference face of every
incident face looking towards it, clipped to the face's side planes and to depth >= 0; the
point is the depth-weighted tangential centroid, ``int d^2 / (2 int d)`` below the plane. That
is the 3-D centroid of the solid between the reference plane and the incident box's front
faces inside the reference face's prism: the reference box intersected with the incident box
*extruded away from the reference face* (swept along the reference normal ``n`` past the plane),
because the extrusion's lower boundary is exactly the front faces and it reaches the plane
everywhere over the footprint. (The plain overlap ``A n B`` differs where a back face of the
incident box dips below the plane inside the prism: by ``tilt x depth / 2`` at most on the
tilted contacts of the tests.)

Method (the divergence theorem): each solid is the convex hull of its vertices. The boundary
of the intersection of two convex polytopes is made of each one's facets clipped to the other
(Sutherland-Hodgman against its half-spaces, which keeps a facet's outward orientation).
Fanning every boundary polygon from its first vertex to an apex O gives signed tetrahedra whose
volumes and moments sum to the intersection's. O is the mean of the boundary's vertices
(inside), so no term is much larger than the volume of a thin overlap. Faces that coincide
(two boxes touching over a face) would count twice: meant for penetrating pairs.
"""
from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

_CORNERS = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))


def box_vertices(size, position, rotation) -> np.ndarray:
    """The 8 vertices (8, 3) of a box, world frame (metres); ``rotation`` (3, 3) has the box's
    axes as columns."""
    return np.asarray(position, float) + (_CORNERS * np.asarray(size, float)) @ np.asarray(
        rotation, float).T


def polytope(vertices) -> tuple:
    """Facets and half-spaces of the convex hull of ``vertices`` (k, 3).

    Returns
    -------
    faces : list of ndarray, each (3, 3)
        Triangles, counter-clockwise seen from outside.
    planes : ndarray, shape (f, 4)
        Half-spaces ``n . x + c <= 0`` (unit outward n).
    """
    hull = ConvexHull(np.asarray(vertices, float))
    faces = []
    for simplex, plane in zip(hull.simplices, hull.equations):
        a, b, c = hull.points[simplex]
        faces.append(np.array([a, b, c] if np.cross(b - a, c - a) @ plane[:3] > 0 else
                              [a, c, b]))
    return faces, hull.equations


def clip(polygon: np.ndarray, plane) -> np.ndarray:
    """The part of a convex polygon (k, 3) with ``n . x + c <= 0`` (Sutherland-Hodgman,
    orientation kept); (0, 3) when nothing is left."""
    if len(polygon) == 0:
        return polygon
    value = polygon @ plane[:3] + plane[3]
    out = []
    for k in range(len(polygon)):
        following = (k + 1) % len(polygon)
        now, then = value[k], value[following]
        if now <= 0.0:
            out.append(polygon[k])
        if (now < 0.0 < then) or (then < 0.0 < now):
            out.append(polygon[k] + now / (now - then) * (polygon[following] - polygon[k]))
    return np.array(out).reshape(-1, 3)


def intersection_centroid(first, second) -> tuple:
    """Volume (m^3) and centroid (3,) (metres) of the intersection of two convex polytopes,
    each given by its vertices (k, 3); (0, NaN) when they do not overlap."""
    solids = [polytope(first), polytope(second)]
    boundary = []
    for (faces, _), (_, planes) in ((solids[0], solids[1]), (solids[1], solids[0])):
        for face in faces:
            for plane in planes:
                face = clip(face, plane)
            if len(face) >= 3:
                boundary.append(face)
    if not boundary:
        return 0.0, np.full(3, np.nan)
    apex = np.concatenate(boundary).mean(axis=0)
    volume, moment = 0.0, np.zeros(3)
    for face in boundary:
        a = face[0] - apex
        for b, c in zip(face[1:-1] - apex, face[2:] - apex):
            tetra = np.dot(a, np.cross(b, c)) / 6.0
            volume += tetra
            moment += tetra * (a + b + c) / 4.0
    return volume, apex + moment / volume


def centre_of_pressure(reference_box, incident_box, normal, floor=0.0) -> np.ndarray:
    """docs/design.md's point (3,) (metres) of a face contact whose reference face is the reference
    box's face with outward unit ``normal`` (world frame, along one of the box's axes).

    Boxes are ``(size (3,), position (3,), rotation (3, 3))``. The incident box is swept along
    ``normal`` by both diagonals plus the distance between the centres, which carries every
    vertex past the reference plane (the extrusion of the module docstring).

    ``floor`` (metres) reproduces a pressure floor tau (:mod:`impactnet.models.box.pressure`): the
    region ``d >= -tau`` under the pressure ``d + tau`` is the same solid with the reference face
    moved out by tau, and the point sits half the true depth ``d = p - tau`` below the true plane,
    i.e. tau / 2 further in than that solid's centroid.
    """
    size, position, rotation = (np.asarray(v, float) for v in reference_box)
    normal = np.asarray(normal, float)
    axis = np.argmax(np.abs(rotation.T @ normal))
    size = size + floor * (np.arange(3) == axis)
    reference = box_vertices(size, position + 0.5 * floor * normal, rotation)
    incident = box_vertices(*incident_box)
    reach = (np.linalg.norm(size) + np.linalg.norm(incident_box[0])
             + np.linalg.norm(np.subtract(incident_box[1], position)))
    swept = np.concatenate([incident, incident + reach * normal])
    return intersection_centroid(reference, swept)[1] - 0.5 * floor * normal


def overlap_along(direction, args) -> np.ndarray:
    """Overlap (metres) of the two boxes along unit world directions, shape (n,).

    ``r_A(u) + r_B(u) - |(p_B - p_A) . u|`` with the support radii from the rotation matrices
    (SciPy's): an implementation apart from both solvers. ``args`` are the six pose arrays.
    """
    size_a, position_a, quaternion_a, size_b, position_b, quaternion_b = args
    radius = 0.0
    for size, quaternion in ((size_a, quaternion_a), (size_b, quaternion_b)):
        rot = Rotation.from_quat(quaternion, scalar_first=True).as_matrix()
        local = np.einsum("nij,ni->nj", rot, direction)
        radius = radius + 0.5 * (np.abs(local) * size).sum(axis=1)
    return radius - np.abs(np.einsum("ni,ni->n", direction, position_b - position_a))
