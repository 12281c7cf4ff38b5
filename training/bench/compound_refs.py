"""References for the compound benchmark, each timed on its own per-pose work only: python-fcl
mesh-mesh (one BVH of each body's part hulls, triangulated), python-fcl ``Convex`` (libccd
GJK/EPA) on the part pairs the oracle's broadphase keeps, and MuJoCo 4 (one geom per part: box
geoms, mesh geoms for convex parts). Each returns seconds per pose (median) and, per pose, the
deepest contact it reports as ``(depth, normal (3,))`` (None without contact), or the set of
touching part pairs.
"""
from __future__ import annotations

import statistics
import time

import numpy as np

from impactnet.models.compound.body_table import body_table
from impactnet.models.compound.broadphase import broadphase
from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart
from impactnet.models.geometry.rotations import quaternion_to_matrix

#: Contacts FCL may return per mesh-mesh query: enough to hold every triangle pair of a stack
#: of castings (FCL returns the first ones found, not the deepest).
FCL_MESH_CONTACTS = 10_000


def _body_mesh(parts) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (T, 3) of all the parts' hulls (body frame)."""
    vertices, triangles, base = [], [], 0
    for part in parts:
        hull = hull_of(part)
        vertices.append(hull.vertices)
        triangles.append(hull.triangles + base)
        base += len(hull.vertices)
    return np.concatenate(vertices), np.concatenate(triangles)


def fcl_mesh(parts_a, parts_b, position, quaternion):
    """(seconds per pose, [(depth, normal) or None per pose]) of FCL mesh-mesh."""
    import fcl

    objects = []
    for parts in (parts_a, parts_b):
        vertices, triangles = _body_mesh(parts)
        model = fcl.BVHModel()
        model.beginModel(len(vertices), len(triangles))
        model.addSubModel(vertices, triangles)
        model.endModel()
        objects.append(fcl.CollisionObject(model))
    rotations = quaternion_to_matrix(quaternion)
    times, deepest = [], []
    for rotation, offset in zip(rotations, position):
        start = time.perf_counter()
        objects[1].setTransform(fcl.Transform(rotation, offset))
        result = fcl.CollisionResult()
        fcl.collide(objects[0], objects[1], fcl.CollisionRequest(
            num_max_contacts=FCL_MESH_CONTACTS, enable_contact=True), result)
        times.append(time.perf_counter() - start)
        best = max(result.contacts, key=lambda c: c.penetration_depth, default=None)
        deepest.append(None if best is None else (best.penetration_depth,
                                                  np.asarray(best.normal, float)))
    return statistics.median(times), deepest


def _convex_object(part):
    import fcl

    if isinstance(part, BoxPart):
        return fcl.CollisionObject(fcl.Box(*part.size)), np.asarray(part.centre, float)
    hull = hull_of(part)
    faces = []
    for f in range(hull.n_faces):
        faces += [int(hull.face_counts[f]), *hull.face_loops[f, :hull.face_counts[f]].tolist()]
    return fcl.CollisionObject(fcl.Convex(hull.vertices, hull.n_faces, np.array(faces))), None


def fcl_convex(parts_a, parts_b, position, quaternion):
    """(seconds per pose, [{(part_a, part_b): (depth, normal)} per pose]) of FCL ``Convex`` /
    ``Box`` on the part pairs the oracle's broadphase keeps."""
    import fcl

    n = len(position)
    rotations = quaternion_to_matrix(quaternion)
    pose, i, j = broadphase(body_table(tuple(parts_a)), body_table(tuple(parts_b)), position,
                            np.broadcast_to(np.eye(3), (n, 3, 3)), rotations)
    objects_a = [_convex_object(p) for p in parts_a]
    objects_b = [_convex_object(p) for p in parts_b]
    for obj, centre in objects_a:
        obj.setTransform(fcl.Transform(centre if centre is not None else np.zeros(3)))
    request = fcl.CollisionRequest(num_max_contacts=1, enable_contact=True,
                                   gjk_solver_type=fcl.GJKSolverType.GST_LIBCCD)
    times, found = [], []
    for k in range(n):
        rows = np.flatnonzero(pose == k)
        start = time.perf_counter()
        pairs = {}
        for a, b in zip(i[rows], j[rows]):
            obj_b, centre = objects_b[b]
            offset = position[k] + (rotations[k] @ centre if centre is not None else 0.0)
            obj_b.setTransform(fcl.Transform(rotations[k], offset))
            result = fcl.CollisionResult()
            fcl.collide(objects_a[a][0], obj_b, request, result)
            if result.contacts:
                c = result.contacts[0]
                pairs[(int(a), int(b))] = (c.penetration_depth, np.asarray(c.normal, float))
        times.append(time.perf_counter() - start)
        found.append(pairs)
    return statistics.median(times), found


def mujoco_seconds(parts_a, parts_b, position, quaternion):
    """(seconds per pose, [{(part_a, part_b): (depth, normal)} per pose]) of MuJoCo 4."""
    import mujoco

    from impactnet.training.bench.compound_mujoco import mujoco_model, part_pairs

    model, data = mujoco_model(parts_a, parts_b)
    times, found = [], []
    for offset, q in zip(position, quaternion):
        data.qpos[:] = np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, offset, q]
        start = time.perf_counter()
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        times.append(time.perf_counter() - start)
        found.append(part_pairs(data, len(parts_a)))
    return statistics.median(times), found
