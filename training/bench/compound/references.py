"""References for the compound benchmark, each timed on its own per-pose work only (placing
B and colliding; models, broadphase and the grouping of contacts are outside the clock):

* python-fcl mesh-mesh: one BVH (``fcl.BVHModel``, OBBRSS) per body holding every part's hull
  triangulated by trimesh (``trimesh.convex.convex_hull``); all triangle-pair contacts asked
  for (:data:`FCL_MESH_CONTACTS`), each mapped back to its part pair through the triangle ids;
* python-fcl ``Convex`` / ``Box`` (libccd GJK/EPA, one contact per pair) on the part pairs that
  the oracle's broadphase keeps (the broadphase itself not timed);
* MuJoCo 4, one geom per part (:mod:`impactnet.training.bench.compound.mujoco_model`), with its
  defaults (``multiccd``: up to four contacts per pair) and with ``multiccd`` off (one EPA
  contact per pair).

Each returns ``(seconds per pose (median), [{(part_a, part_b): (depth (m), normal (3,))} per
pose])``, the deepest contact per part pair, normals as the reference gives them (FCL: from A
towards B; MuJoCo: flipped into A towards B).
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


def body_mesh(parts) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (V, 3) m, triangles (T, 3) and the part of each triangle (T,) of a body whose
    parts' hulls trimesh triangulates (body frame)."""
    import trimesh

    vertices, triangles, owner, base = [], [], [], 0
    for k, part in enumerate(parts):
        mesh = trimesh.convex.convex_hull(hull_of(part).vertices)
        vertices.append(np.asarray(mesh.vertices, float))
        triangles.append(np.asarray(mesh.faces) + base)
        owner.append(np.full(len(mesh.faces), k))
        base += len(mesh.vertices)
    return np.concatenate(vertices), np.concatenate(triangles), np.concatenate(owner)


def _deepest(pairs: dict, key, depth: float, normal) -> None:
    if key not in pairs or depth > pairs[key][0]:
        pairs[key] = (float(depth), np.asarray(normal, float))


def fcl_mesh(parts_a, parts_b, position, quaternion):
    """FCL mesh-mesh on n poses of B (position (n, 3) m, quaternion (n, 4)) against A at the
    origin: (seconds per pose, per-pose part-pair contacts), module docstring."""
    import fcl

    objects, owners = [], []
    for parts in (parts_a, parts_b):
        vertices, triangles, owner = body_mesh(parts)
        model = fcl.BVHModel()
        model.beginModel(len(vertices), len(triangles))
        model.addSubModel(vertices, triangles)
        model.endModel()
        objects.append(fcl.CollisionObject(model))
        owners.append(owner)
    request = fcl.CollisionRequest(num_max_contacts=FCL_MESH_CONTACTS, enable_contact=True)
    times, found = [], []
    for rotation, offset in zip(quaternion_to_matrix(quaternion), position):
        start = time.perf_counter()
        objects[1].setTransform(fcl.Transform(rotation, offset))
        result = fcl.CollisionResult()
        fcl.collide(objects[0], objects[1], request, result)
        times.append(time.perf_counter() - start)
        pairs: dict = {}
        for c in result.contacts:
            key = (int(owners[0][c.b1]), int(owners[1][c.b2]))
            _deepest(pairs, key, c.penetration_depth, c.normal)
        found.append(pairs)
    return statistics.median(times), found


def _convex_object(part):
    """(collision object, centre (3,) m or None): a box part as ``fcl.Box`` at its centre, a
    convex part as ``fcl.Convex`` of its hull in the body frame."""
    import fcl

    if isinstance(part, BoxPart):
        return fcl.CollisionObject(fcl.Box(*part.size)), np.asarray(part.centre, float)
    hull = hull_of(part)
    faces = []
    for f in range(hull.n_faces):
        faces += [int(hull.face_counts[f]), *hull.face_loops[f, :hull.face_counts[f]].tolist()]
    return fcl.CollisionObject(fcl.Convex(hull.vertices, hull.n_faces, np.array(faces))), None


def fcl_convex(parts_a, parts_b, position, quaternion):
    """FCL ``Convex`` / ``Box`` per part pair that the oracle's broadphase keeps: (seconds per
    pose, per-pose part-pair contacts)."""
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
    bounds = np.searchsorted(pose, np.arange(n + 1))  # rows of pose k: bounds[k]:bounds[k+1]
    times, found = [], []
    for k in range(n):
        rows = slice(bounds[k], bounds[k + 1])
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


def mujoco(parts_a, parts_b, position, quaternion, multiccd: bool = True):
    """MuJoCo 4 (``mj_kinematics`` and ``mj_collision`` per pose): (seconds per pose, per-pose
    part-pair contacts); ``multiccd`` as in :func:`.mujoco_model.mujoco_model`."""
    import mujoco as mj

    from impactnet.training.bench.compound.mujoco_model import mujoco_model, part_pairs

    model, data = mujoco_model(parts_a, parts_b, multiccd=multiccd)
    times, found = [], []
    for offset, q in zip(position, quaternion):
        data.qpos[:] = np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, offset, q]
        start = time.perf_counter()
        mj.mj_kinematics(model, data)
        mj.mj_collision(model, data)
        times.append(time.perf_counter() - start)
        found.append(part_pairs(data, len(parts_a)))
    return statistics.median(times), found


def mujoco_single(parts_a, parts_b, position, quaternion):
    """:func:`mujoco` with ``multiccd`` off: one EPA contact per geom pair."""
    return mujoco(parts_a, parts_b, position, quaternion, multiccd=False)


#: The references of the benchmark: (key, label, function), in table order.
REFERENCES = (("fcl_mesh", "FCL mesh-mesh", fcl_mesh),
              ("fcl_convex", "FCL Convex", fcl_convex),
              ("mujoco", "MuJoCo", mujoco),
              ("mujoco_epa", "MuJoCo, multiccd off", mujoco_single))
