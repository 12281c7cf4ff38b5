"""Test helper: python-fcl's box-box collide as an independent reference, in impactnet terms.

Not a test module. :func:`fcl_box_box` loops over rows (FCL has no batch API) and returns
FCL's contacts converted to impactnet conventions (docs/design.md: normal from A towards B,
depth >= 0, point on the mid-surface).

python-fcl 0.7.0.11 conventions, found empirically (cubes of edge 2 unless said otherwise;
A = o1, B = o2; the scripts were run once, the key cases are re-checked in
``tests/models/box/test_fcl_reference.py``)
--------------------------------------------------------------------------------------------
* Solver path. Both ``GJKSolverType.GST_LIBCCD`` (python-fcl's default) and ``GST_INDEP``
  send Box-Box to FCL's analytic ``boxBoxIntersect`` (a port of ODE's dBoxBox, file
  ``fcl/narrowphase/detail/primitive_shape_algorithm/box_box-inl.h``), not to GJK/EPA:
  both return identical contacts on 20,000 random poses, and a face-face stack returns 4
  contacts, which EPA (one point) never does. We use ``GST_INDEP`` explicitly.
* Sizes. ``fcl.Box(x, y, z)`` takes FULL side lengths: with B at (0, 0, 2.01) the cubes are
  separated, at (0, 0, 1.99) they collide. Exactly touching (B at (0, 0, 2)) counts as
  colliding, with 4 contacts of depth 0 (FCL separates only on a strictly positive gap).
* Quaternions. ``fcl.Transform(q, t)`` reads ``q`` as (w, x, y, z) (Eigen's constructor
  order): q = (cos 45deg, 0, 0, sin 45deg) gives the +90deg rotation about z. This module
  passes rotation matrices built with scipy anyway.
* Normal. ``Contact.normal`` is a unit vector pointing from o1 towards o2, i.e. impactnet's
  A -> B. B at (0, 0, +1.9): normal (0, 0, 1); B at (0, 0, -1.9): (0, 0, -1); swapping o1 and
  o2 flips it. It is the same for every contact of a pair (one SAT axis).
* Depth. ``penetration_depth`` is >= 0: 0.1 for B at (0, 0, 1.9).
* Points: every point lies on the MID-SURFACE (already impactnet's convention):
  (a) vertex of B (edge 0.5, vertex down) pushed 0.05 into A's +z face at (0.1, 0.2): one
      contact at (0.1, 0.2, 0.975) = B's vertex (z 0.95) + normal * depth / 2;
  (b) vertex of A (edge 0.5, vertex up, at z 0.4330) pushed 0.05 into B's -z face (reference
      face is B's): one contact at z 0.4080 = A's vertex - normal * depth / 2, normal +z;
  (c) edge-edge at 90deg (A turned 45deg about x, ridge along x at z = sqrt 2; B turned
      45deg about y, ridge along y at x = 0.3; pushed 0.05): one contact at
      (0.3, 0, sqrt 2 - 0.025), the midpoint of the two closest points, normal +z;
  (d) face-face stack (B of edge 1 at (0.3, 0.2, 1.45)): 4 contacts at the corners of B's
      bottom face, z = 0.975 (mid-surface), depth 0.05 each. Edge-face (B's edge on A's
      face) gives 2 contacts, the clipped ends of the edge, also at mid-surface height.
  So for one contact: point on A's boundary = pos + normal * depth / 2, point on B's boundary
  = pos - normal * depth / 2 (see :func:`fcl_contact_to_impactnet`).
* Contact count. The box-box routine is called with its own maxc = 4, whatever
  ``num_max_contacts`` says: a face-face contact whose clipped polygon has 8 vertices (B
  turned 30deg or 45deg about z on top of A) comes back as 4 points (ODE's cullPoints: the
  deepest point and three others spread in angle about the centroid). If
  ``num_max_contacts`` is smaller than what box-box returns, FCL keeps the deepest ones.
  With ties (the 45deg octagon, all 8 points equally deep) the last bit of the rotation
  decides which 4 survive: q and -q gave two different subsets. So FCL's manifold differs
  from impactnet's (the whole clipped polygon) whenever culling happened, and FCL's point (a
  mean of its contacts) is not impactnet's centre of pressure of the footprint for any face
  contact: only single-point contacts (edge-edge, and a vertex's manifold point) compare.
* Fudge factor. FCL 0.7 keeps ODE's ``fudge_factor = 1.05`` but only in the axis SELECTION:
  an edge axis replaces the current best axis only if ``1.05 * its penetration`` is smaller;
  the depth it reports for the chosen axis is unscaled. Since the current best may itself
  be an edge axis, a later edge axis also needs a 5% margin over an earlier one. On 20,000
  uniform random poses pushed in by up to 5% of the shortest edge, 150 (0.75%) got an axis
  other than the exact minimum (136 a face axis instead of an edge axis, 14 an earlier edge
  axis); that axis's overlap exceeded the true minimum by up to 4.98% (median 2.4%), the
  reported depth (largest contact depth) by up to 4.9%, and the normal was off by up to 54deg
  (median 1.1deg). Analytic example: B turned Rz(45deg) Ry(5deg), approaching along
  (1, 1, 0)/sqrt 2 and pushed 0.2 past first touch; exact: A's z-edge x B's y-edge, normal
  (1, 1, 0)/sqrt 2, depth 0.2; FCL: B's face normal (0.7044, 0.7044, -0.0872) (5deg off),
  2 contacts, depths 0.2008 and 0.0329 (that face's overlap is 0.2072 = 1.036 * 0.2).
  ODE's other fudge (adding 1e-5 to every |R_ij| for the cross axes) is replaced in FCL 0.7
  by a scale-aware pad ``10 * eps * max(1, largest half-extent)``; its effect on an
  edge-edge depth is ``pad * (ha_i1 + ha_i2 + hb_j1 + hb_j2) / sin(edge angle)`` (measured
  over predicted excess: median 1.000 for boxes of 0.2-3 m, 2-30 m and 20-300 m): FCL's
  edge-edge depths are too large by 1e-15 to 2e-13 m for metre-sized boxes, never too
  small. Negligible next to the fudge.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import fcl
import numpy as np
from scipy.spatial.transform import Rotation

#: FCL solver used for the pair; both solver types take the analytic box-box path.
SOLVER = fcl.GJKSolverType.GST_INDEP


@dataclass
class FclBoxBox:
    """FCL's answer for N box pairs, in impactnet conventions (world frame, metres).

    Attributes
    ----------
    colliding : ndarray of bool, shape (n,)
        FCL's boolean collide (touching counts as colliding).
    normal : ndarray, shape (n, 3)
        Unit normal from A towards B (shared by all contacts of a row); 0 where separated.
    depth : ndarray, shape (n,)
        Largest contact penetration depth (python-fcl does not expose the SAT axis depth,
        which can exceed it for face contacts); 0 where separated.
    point : ndarray, shape (n, 3)
        Depth-weighted mean of the contact points (plain mean when all depths are 0); for a
        single-point contact the point itself. 0 where separated.
    points : list of ndarray, each shape (k_i, 3)
        FCL's contact points (mid-surface), k_i <= 4.
    depths : list of ndarray, each shape (k_i,)
        Their penetration depths (>= 0).
    """

    colliding: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    point: np.ndarray
    points: list = field(default_factory=list)
    depths: list = field(default_factory=list)


def _rotation_matrices(quaternion):
    """(n, 4) quaternions (w, x, y, z), any norm and sign -> (n, 3, 3) rotation matrices."""
    q = np.atleast_2d(np.asarray(quaternion, dtype=np.float64))
    return Rotation.from_quat(q, scalar_first=True).as_matrix()


def _rows(x, width):
    return np.atleast_2d(np.asarray(x, dtype=np.float64)).reshape(-1, width)


def manifold_point(points, depths):
    """Depth-weighted mean of contact points (plain mean if every depth is 0).

    Parameters
    ----------
    points : array_like, shape (k, 3)
        Contact points in metres, k >= 1.
    depths : array_like, shape (k,)
        Their penetration depths in metres (>= 0).

    Returns
    -------
    ndarray, shape (3,)
    """
    points = np.asarray(points, dtype=np.float64)
    depths = np.asarray(depths, dtype=np.float64)
    total = depths.sum()
    if total > 0.0:
        return (depths[:, None] * points).sum(axis=0) / total
    return points.mean(axis=0)


def fcl_contact_to_impactnet(normal, pos, depth):
    """Convert one FCL single-point contact (vertex-face, face-vertex, edge-edge) to impactnet.

    FCL's box-box already puts the point on the mid-surface and the normal from o1 (A) to o2
    (B) (see the module docstring), so ``point`` is ``pos`` itself; the two boundary points
    are half a depth away on either side.

    Parameters
    ----------
    normal : array_like, shape (3,)
        ``Contact.normal`` (unit, o1 -> o2).
    pos : array_like, shape (3,)
        ``Contact.pos`` in metres.
    depth : float
        ``Contact.penetration_depth`` in metres.

    Returns
    -------
    dict
        ``normal`` (3,), ``point`` (3,) on the mid-surface, ``depth`` (float),
        ``point_on_a`` (3,) = deepest point of A inside B (A's vertex or edge point, or the
        point of A's face opposite B's vertex) = pos + normal * depth / 2, and ``point_on_b``
        (3,) = pos - normal * depth / 2.
    """
    normal = np.asarray(normal, dtype=np.float64)
    pos = np.asarray(pos, dtype=np.float64)
    half = 0.5 * float(depth) * normal
    return {
        "normal": normal,
        "point": pos.copy(),
        "depth": float(depth),
        "point_on_a": pos + half,
        "point_on_b": pos - half,
    }


def fcl_box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b,
                max_contacts=16, solver=SOLVER):
    """Collide N box pairs with python-fcl (contacts on), one row at a time.

    Parameters
    ----------
    size_a, size_b : array_like, shape (n, 3) or (3,)
        Full edge lengths in metres.
    position_a, position_b : array_like, shape (n, 3) or (3,)
        Box centres in the world frame, metres.
    quaternion_a, quaternion_b : array_like, shape (n, 4) or (4,)
        Orientations (w, x, y, z); normalised here.
    max_contacts : int, optional
        ``CollisionRequest.num_max_contacts``; FCL's box-box returns at most 4 anyway.
    solver : int, optional
        ``fcl.GJKSolverType``; both types give the same analytic box-box answer.

    Returns
    -------
    FclBoxBox
    """
    size_a, size_b = _rows(size_a, 3), _rows(size_b, 3)
    position_a, position_b = _rows(position_a, 3), _rows(position_b, 3)
    rot_a, rot_b = _rotation_matrices(quaternion_a), _rotation_matrices(quaternion_b)
    n = max(len(size_a), len(size_b), len(position_a), len(position_b), len(rot_a), len(rot_b))
    size_a, size_b = np.broadcast_to(size_a, (n, 3)), np.broadcast_to(size_b, (n, 3))
    position_a = np.broadcast_to(position_a, (n, 3))
    position_b = np.broadcast_to(position_b, (n, 3))
    rot_a, rot_b = np.broadcast_to(rot_a, (n, 3, 3)), np.broadcast_to(rot_b, (n, 3, 3))

    out = FclBoxBox(
        colliding=np.zeros(n, dtype=bool),
        normal=np.zeros((n, 3)),
        depth=np.zeros(n),
        point=np.zeros((n, 3)),
    )
    for row in range(n):
        o1 = fcl.CollisionObject(fcl.Box(*size_a[row]), fcl.Transform(rot_a[row], position_a[row]))
        o2 = fcl.CollisionObject(fcl.Box(*size_b[row]), fcl.Transform(rot_b[row], position_b[row]))
        request = fcl.CollisionRequest(
            num_max_contacts=max_contacts, enable_contact=True, gjk_solver_type=solver
        )
        result = fcl.CollisionResult()
        fcl.collide(o1, o2, request, result)
        pts = np.array([c.pos for c in result.contacts], dtype=np.float64).reshape(-1, 3)
        deps = np.array([c.penetration_depth for c in result.contacts], dtype=np.float64)
        out.points.append(pts)
        out.depths.append(deps)
        out.colliding[row] = bool(result.is_collision)
        if len(deps):
            out.normal[row] = result.contacts[0].normal
            out.depth[row] = deps.max()
            out.point[row] = manifold_point(pts, deps)
    return out
