"""Test helper: MuJoCo 4's collider on two compound bodies, one geom per part.

Not a test module. Each body is a free MuJoCo body holding one geom per part: a box geom (half-
extents, at the part's centre) for a box part, a mesh geom of the hull's vertices (in the
body's frame; MuJoCo collides the hull) for a convex part; margins 0; MuJoCo never collides
geoms of the same body, as the oracle never pairs parts of one body. Per pose the two free
joints' ``qpos`` are set, then ``mj_kinematics`` and ``mj_collision`` run; the contacts are
grouped by geom pair: per part pair the deepest depth (``-dist``) and the normal
(``frame[0:3]``, from the first geom to the second, flipped where MuJoCo put B's geom first).
MuJoCo knows nothing of parts that overlap within a body, so a pair whose touched surface one
body covers with other parts (each contact position moved half its depth back onto that body's
part, all inside its other parts) is left out: the oracle's documented filter, applied to
MuJoCo's own contacts. Conventions as in ``impactnet.training.bench.mujoco_reference`` (which
the model tests may not import).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart
from impactnet.models.geometry.rotations import quaternion_to_matrix

_BODY = '<body name="{name}"><freejoint/>{geoms}</body>'
_GEOM = ('<geom name="{body}{k}" type="box" size="{half}" pos="{pos}" margin="0" gap="0" '
         'contype="1" conaffinity="1"/>')
_MESH_GEOM = ('<geom name="{body}{k}" type="mesh" mesh="{body}m{k}" margin="0" gap="0" '
              'contype="1" conaffinity="1"/>')
_MESH = '<mesh name="{body}m{k}" vertex="{vertex}"/>'



def _floats(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _model(parts_a, parts_b):
    import mujoco

    bodies, meshes = [], []
    for name, parts in (("a", parts_a), ("b", parts_b)):
        geoms = []
        for k, p in enumerate(parts):
            if isinstance(p, BoxPart):
                geoms.append(_GEOM.format(body=name, k=k, half=_floats(0.5 * np.asarray(p.size)),
                                          pos=_floats(p.centre)))
            else:
                meshes.append(_MESH.format(body=name, k=k,
                                           vertex=_floats(hull_of(p).vertices.ravel())))
                geoms.append(_MESH_GEOM.format(body=name, k=k))
        bodies.append(_BODY.format(name=name, geoms="".join(geoms)))
    xml = ('<mujoco><option gravity="0 0 0" ccd_tolerance="1e-12" ccd_iterations="2000"/>'
           '<asset>' + "".join(meshes) + '</asset><worldbody>' + "".join(bodies)
           + "</worldbody></mujoco>")
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def mujoco_part_contacts(parts_a, parts_b, position_b, quaternion_b) -> list[dict]:
    """Per pose (A at the origin, unrotated; B at ``position_b`` (n, 3), ``quaternion_b``
    (n, 4)), a dict ``(part_a, part_b) -> (depth, normal (3,))`` of the touching part pairs."""
    import mujoco

    model, data = _model(parts_a, parts_b)
    count_a = len(parts_a)
    out = []
    for position, quaternion in zip(np.asarray(position_b, float),
                                    np.asarray(quaternion_b, float)):
        data.qpos[:] = np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, position, quaternion]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        pairs: dict = {}
        points: dict = {}
        for c in range(int(data.ncon)):
            contact = data.contact[c]
            g1, g2 = int(contact.geom[0]), int(contact.geom[1])
            normal = np.array(contact.frame[0:3])
            if g1 >= count_a:  # B's geom first: flip into A -> B
                g1, g2, normal = g2, g1, -normal
            key, depth = (g1, g2 - count_a), -float(contact.dist)
            points.setdefault(key, []).append((np.array(contact.pos), depth, normal))
            if key not in pairs or depth > pairs[key][0]:
                pairs[key] = (depth, normal)
        rot_b = quaternion_to_matrix(quaternion / np.linalg.norm(quaternion))[0]
        out.append({key: value for key, value in pairs.items()
                    if not _hidden(points[key], key, parts_a, parts_b, position, rot_b)})
    return out


def _hidden(contacts, key, parts_a, parts_b, position_b, rot_b) -> bool:
    """All of A's surface points (each contact position moved half its depth along the
    normal) covered by other parts of A, or all of B's (the other way) by other parts of B."""
    on_a = all(_covered_in(p + 0.5 * d * n, key[0], parts_a, np.eye(3), np.zeros(3))
               for p, d, n in contacts)
    on_b = all(_covered_in(p - 0.5 * d * n, key[1], parts_b, rot_b, position_b)
               for p, d, n in contacts)
    return on_a or on_b


def _covered_in(point, own, parts, rot, position, margin_rel=1e-9) -> bool:
    """Whether ``point`` (world) lies strictly inside a part of the body other than ``own``."""
    local = rot.T @ (point - position)
    for k, part in enumerate(parts):
        hull = hull_of(part)
        extent = np.ptp(hull.vertices, axis=0).min()
        if k != own and (hull.face_normals @ local - hull.face_offsets
                         < -margin_rel * extent).all():
            return True
    return False
