"""Test helper: python-fcl's and MuJoCo's distance queries on the same poses, as independent
references of the gap query (and the timings' competitors).

Not a test module.

* FCL (python-fcl 0.7): ``fcl.distance`` with ``DistanceRequest(enable_nearest_points=True)``
  between a ``fcl.Box`` (full edges) or a ``fcl.Convex`` (the hull's vertices and face loops)
  per body, placed by ``fcl.Transform(R, p)``; it returns the distance and the nearest points
  (world frame). python-fcl passes no tolerance: FCL's defaults apply (GJK solver libccd,
  ``distance_tolerance`` 1e-6, 1,000 iterations at most).
* MuJoCo: ``mj_geomDistance`` between two free bodies' geoms, a ``box`` geom (half-extents) or
  a ``mesh`` geom (MuJoCo collides its hull), ``distmax`` :data:`MUJOCO_DISTMAX` (above the 1 m
  gaps), ``opt.ccd_tolerance`` :data:`MUJOCO_CCD_TOLERANCE` and ``opt.ccd_iterations``
  :data:`MUJOCO_CCD_ITERATIONS`; it returns the distance and the segment ``fromto`` (on A's
  geom, on B's). MuJoCo keeps a mesh's vertices as float32 about the mesh's centre and along
  its inertia axes (``geom_pos``, ``geom_quat``); :func:`mujoco_vertices` gives those vertices
  back in the body frame, so that the gap query can be asked about the very same polytope.
"""
from __future__ import annotations

import numpy as np

#: MuJoCo's distmax (m): above every gap of the tests (0-1 m).
MUJOCO_DISTMAX = 2.0
#: MuJoCo's GJK tolerance and iteration cap (its defaults are 1e-6 and 35; the first figure
#: bounds the error of a distance that GJK did not end exactly).
MUJOCO_CCD_TOLERANCE, MUJOCO_CCD_ITERATIONS = 1e-12, 1000


def is_box(vertices) -> bool:
    """Whether ``vertices`` (k, 3) are the 8 corners of a box about the origin, axis-aligned."""
    v = np.asarray(vertices, float)
    half = np.abs(v).max(axis=0)
    return len(v) == 8 and bool(np.allclose(np.abs(v), half, rtol=0.0, atol=1e-15))


def fcl_geometry(vertices):
    """A ``fcl.Box`` for a box's corners, else a ``fcl.Convex`` of the hull."""
    import fcl

    from impactnet.models.compound.hull import convex_hull

    if is_box(vertices):
        return fcl.Box(*(2.0 * np.abs(np.asarray(vertices)).max(axis=0)))
    hull = convex_hull(vertices)
    faces = []
    for f, count in enumerate(hull.face_counts):
        faces += [int(count)] + [int(i) for i in hull.face_loops[f, :count]]
    return fcl.Convex(hull.vertices, len(hull.face_counts), np.array(faces))


def fcl_gaps(case):
    """FCL's (distance (n,), point on A (n, 3), point on B (n, 3)) at the case's poses."""
    import fcl

    a = fcl.CollisionObject(fcl_geometry(case.vertices_a), fcl.Transform())
    b = fcl.CollisionObject(fcl_geometry(case.vertices_b), fcl.Transform())
    n = len(case.gap)
    distance, on_a, on_b = np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    for i in range(n):
        a.setTransform(fcl.Transform(case.rotation_a[i], case.position_a[i]))
        b.setTransform(fcl.Transform(case.rotation_b[i], case.position_b[i]))
        result = fcl.DistanceResult()
        distance[i] = fcl.distance(a, b, fcl.DistanceRequest(enable_nearest_points=True),
                                   result)
        on_a[i], on_b[i] = result.nearest_points
    return distance, on_a, on_b


def _geom(name: str, vertices) -> tuple[str, str]:
    """(asset, geom) XML of one body's polytope."""
    v = np.asarray(vertices, float)
    if is_box(v):
        half = " ".join(repr(float(x)) for x in np.abs(v).max(axis=0))
        return "", f'<geom name="{name}" type="box" size="{half}"/>'
    points = " ".join(repr(float(x)) for x in v.ravel())
    return (f'<mesh name="{name}m" vertex="{points}"/>',
            f'<geom name="{name}" type="mesh" mesh="{name}m"/>')


def mujoco_model(vertices_a, vertices_b):
    """(MjModel, MjData): free bodies A (qpos 0-6) and B (qpos 7-13), one geom each."""
    import mujoco

    asset_a, geom_a = _geom("a", vertices_a)
    asset_b, geom_b = _geom("b", vertices_b)
    xml = (f'<mujoco><option ccd_tolerance="{MUJOCO_CCD_TOLERANCE!r}" '
           f'ccd_iterations="{MUJOCO_CCD_ITERATIONS}"/><asset>{asset_a}{asset_b}</asset>'
           f'<worldbody><body name="A"><freejoint/>{geom_a}</body><body name="B"><freejoint/>'
           f'{geom_b}</body></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def mujoco_vertices(model, geom: int) -> np.ndarray:
    """The polytope MuJoCo collides for ``geom``, body frame (k, 3) m: a box's corners, or the
    mesh's float32 vertices placed by the geom's ``pos`` and ``quat``."""
    import mujoco

    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_BOX:
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        return signs * model.geom_size[geom]
    mesh = model.geom_dataid[geom]
    start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
    local = model.mesh_vert[start:start + count].astype(np.float64)
    return local @ rotation.reshape(3, 3).T + model.geom_pos[geom]


def mujoco_quaternions(rotation) -> np.ndarray:
    """Unit quaternions [w, x, y, z] (n, 4) of rotation matrices (n, 3, 3)."""
    from impactnet.models.geometry.rotations import matrix_to_quaternion

    return matrix_to_quaternion(rotation)


def mujoco_gaps(model, data, case):
    """MuJoCo's (distance (n,), point on A (n, 3), point on B (n, 3)) at the case's poses."""
    import mujoco

    qa, qb = mujoco_quaternions(case.rotation_a), mujoco_quaternions(case.rotation_b)
    n = len(case.gap)
    distance, fromto = np.empty(n), np.zeros((n, 6))
    for i in range(n):
        data.qpos[:] = np.r_[case.position_a[i], qa[i], case.position_b[i], qb[i]]
        mujoco.mj_kinematics(model, data)
        distance[i] = mujoco.mj_geomDistance(model, data, 0, 1, MUJOCO_DISTMAX, fromto[i])
    return distance, fromto[:, :3], fromto[:, 3:]
