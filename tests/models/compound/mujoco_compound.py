"""Test helper: MuJoCo 4's collider on two compound bodies, one geom per part.

Not a test module. Each body is a free MuJoCo body holding one geom per part: a box geom (half-
extents, at the part's centre) for a box part, a mesh geom of the hull's vertices (in the
body's frame; MuJoCo collides the hull) for a convex part; margins 0; MuJoCo never collides
geoms of the same body, as the oracle never pairs parts of one body. Per pose the two free
joints' ``qpos`` are set, then ``mj_kinematics`` and ``mj_collision`` run twice:

* with MuJoCo's defaults (``multiccd`` on): a pair with a mesh geom gets up to four contacts,
  the vertices of its clipped contact polygon pruned to the largest-area quadrilateral
  (``polygonQuad`` in ``engine_collision_gjk.c``), each with its own depth below the
  reference face;
* with ``multiccd`` disabled: one contact per geom pair, MuJoCo's native GJK/EPA penetration
  (depth and normal of the least translation that separates the two hulls).

Box-box pairs go through MuJoCo's box-box collider in both passes. Per part pair the reference
reports the depth (``-dist``) and normal (``frame[0:3]``, from the first geom to the second,
flipped where MuJoCo put B's geom first) of the single EPA contact (``depth_from="epa"``, the
default), or the deepest of the default pass's contacts (``depth_from="multiccd"``). The
default pass's deepest is not the pair's penetration: the quadrilateral drops the clipped
polygon's other vertices, the deepest among them where the polygon has more than four (a ring
piece under a tilted casting), so it falls short by up to the tilt times the piece's extent
(measured on stacking: up to 5.7e-5 m; see test_oracle_vs_mujoco.py).

MuJoCo knows nothing of parts that overlap within a body, so a pair whose touched surface one
body covers with other parts (every contact position of both passes moved half its depth back
onto that body's part, all inside its other parts) is left out: the oracle's documented filter,
applied to MuJoCo's own contacts. The default pass's polygon corners are what make it
reliable: the single EPA contact is one witness point, which may sit on the seam between two
ring pieces and so inside the neighbour. Conventions as in
``impactnet.training.bench.accuracy.mujoco_reference`` (which the model tests may not import).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart
from impactnet.models.geometry.rotations import quaternion_to_matrix

_BODY = '<body name="{name}"><freejoint/>{geoms}</body>'
_GEOM = ('<geom name="{body}{k}" type="box" size="{half}" pos="{pos}" margin="0" gap="0" '
         'contype="1" conaffinity="1"/>')
_MESH_GEOM = ('<geom name="{body}{k}" type="mesh" mesh="{body}m{k}" pos="{pos}" margin="0" '
              'gap="0" contype="1" conaffinity="1"/>')
_MESH = '<mesh name="{body}m{k}" vertex="{vertex}"/>'
#: GJK/EPA settings of the reference, far beyond MuJoCo's defaults (1e-6 m, 35 iterations): the
#: cap bounds EPA's iterations (at most 1,000) and polytope (6 x cap faces); for box and mesh
#: geoms MuJoCo ignores the tolerance and ends EPA at a repeated support vertex.
CCD_TOLERANCE, CCD_ITERATIONS = 1e-12, 2000
#: A contact position counts as covered by another part of its body when it lies that far
#: (x that part's smallest extent) inside all of its faces. Above the oracle's 1e-9: MuJoCo
#: stores mesh vertices as float32 (rounding ~6e-8 of a coordinate), so a point on a face that
#: another part shares (a ring piece's underside on a cavity wall's top) lands either side of
#: it by ~1e-9 m; far below any part's thickness.
INSIDE_MARGIN_REL = 1e-6


def _floats(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _model(parts_a, parts_b):
    """(MjModel, MjData) of A (qpos 0-6) and B (qpos 7-13), free bodies, MuJoCo's defaults
    but for the EPA settings above. A mesh's vertices are given about its bounding box's centre
    (the geom's ``pos``): MuJoCo keeps them as float32, which rounds a coordinate of 6 m by
    3.6e-7 m and one of 5 cm by 4e-9 m."""
    import mujoco

    bodies, meshes = [], []
    for name, parts in (("a", parts_a), ("b", parts_b)):
        geoms = []
        for k, p in enumerate(parts):
            if isinstance(p, BoxPart):
                geoms.append(_GEOM.format(body=name, k=k, half=_floats(0.5 * np.asarray(p.size)),
                                          pos=_floats(p.centre)))
            else:
                vertices = hull_of(p).vertices
                centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
                meshes.append(_MESH.format(body=name, k=k,
                                           vertex=_floats((vertices - centre).ravel())))
                geoms.append(_MESH_GEOM.format(body=name, k=k, pos=_floats(centre)))
        bodies.append(_BODY.format(name=name, geoms="".join(geoms)))
    xml = (f'<mujoco><option gravity="0 0 0" ccd_tolerance="{CCD_TOLERANCE!r}" '
           f'ccd_iterations="{CCD_ITERATIONS}"/>'
           '<asset>' + "".join(meshes) + '</asset><worldbody>' + "".join(bodies)
           + "</worldbody></mujoco>")
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def _collide(model, data, count_a: int, multiccd: bool) -> dict:
    """``{(part_a, part_b): [(position (3,), depth, normal (3,)), ...]}`` of one pass."""
    import mujoco

    bit = int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
    model.opt.disableflags = (model.opt.disableflags & ~bit) | (0 if multiccd else bit)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)
    found: dict = {}
    for c in range(int(data.ncon)):
        contact = data.contact[c]
        g1, g2 = int(contact.geom[0]), int(contact.geom[1])
        normal = np.array(contact.frame[0:3])
        if g1 >= count_a:  # B's geom first: flip into A -> B
            g1, g2, normal = g2, g1, -normal
        found.setdefault((g1, g2 - count_a), []).append(
            (np.array(contact.pos), -float(contact.dist), normal))
    return found


def mujoco_part_contacts(parts_a, parts_b, position_b, quaternion_b,
                         depth_from: str = "epa") -> list[dict]:
    """Per pose (A at the origin, unrotated; B at ``position_b`` (n, 3) m, ``quaternion_b``
    (n, 4)), a dict ``(part_a, part_b) -> (depth (m), normal (3,))`` of the touching part
    pairs; ``depth_from`` is ``"epa"`` (one EPA contact per pair) or ``"multiccd"`` (the
    deepest of MuJoCo's default contacts), module docstring."""
    if depth_from not in ("epa", "multiccd"):
        raise ValueError(f"depth_from must be 'epa' or 'multiccd', got {depth_from!r}")
    model, data = _model(parts_a, parts_b)
    count_a = len(parts_a)
    covers = (_cover_table(parts_a), _cover_table(parts_b))
    out = []
    for position, quaternion in zip(np.asarray(position_b, float),
                                    np.asarray(quaternion_b, float)):
        data.qpos[:] = np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, position, quaternion]
        polygon = _collide(model, data, count_a, multiccd=True)
        single = _collide(model, data, count_a, multiccd=False)
        chosen = single if depth_from == "epa" else polygon
        rot_b = quaternion_to_matrix(quaternion / np.linalg.norm(quaternion))[0]
        pairs = {}
        for key, contacts in chosen.items():
            points = contacts + polygon.get(key, []) + single.get(key, [])
            if not _hidden(points, key, covers, position, rot_b):
                _, depth, normal = max(contacts, key=lambda c: c[1])
                pairs[key] = (depth, normal)
        out.append(pairs)
    return out


def _cover_table(parts) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every part's face planes, padded: normals (P, F, 3), offsets (P, F) (padding +inf, never
    binding) and the margin (P,) m of :data:`INSIDE_MARGIN_REL`."""
    hulls = [hull_of(p) for p in parts]
    faces = max(h.n_faces for h in hulls)
    normals = np.zeros((len(hulls), faces, 3))
    offsets = np.full((len(hulls), faces), np.inf)
    for k, hull in enumerate(hulls):
        normals[k, :hull.n_faces] = hull.face_normals
        offsets[k, :hull.n_faces] = hull.face_offsets
    margin = np.array([INSIDE_MARGIN_REL * np.ptp(h.vertices, axis=0).min() for h in hulls])
    return normals, offsets, margin


def _hidden(contacts, key, covers, position_b, rot_b) -> bool:
    """All of A's surface points (each contact position moved half its depth along the
    normal) covered by other parts of A, or all of B's (the other way) by other parts of B."""
    pos = np.array([c[0] for c in contacts])
    half = np.array([0.5 * c[1] * c[2] for c in contacts])
    on_a = _covered(pos + half, key[0], covers[0])
    on_b = _covered((pos - half - position_b) @ rot_b, key[1], covers[1])
    return bool(on_a.all() or on_b.all())


def _covered(local: np.ndarray, own: int, cover) -> np.ndarray:
    """(m,) whether each point ``local`` (m, 3), body frame, lies strictly inside a part of the
    body other than ``own``."""
    normals, offsets, margin = cover
    distance = np.einsum("pfj,mj->mpf", normals, local) - offsets  # (m, P, F)
    inside = (distance < -margin[None, :, None]).all(axis=2)
    inside[:, own] = False
    return inside.any(axis=1)
