"""MuJoCo 4 model of two compound bodies for the benchmark: one free body each, one geom per
part (a box geom for a box part, a mesh geom of the hull's vertices for a convex part), margins
0, MuJoCo's default collision options; contacts grouped by part pair, the deepest kept, normals
from A's part towards B's.

A mesh's vertices are given about the centre of its bounding box, the geom placed there: MuJoCo
stores mesh vertices as float32, which would round a coordinate of 6 m (a casting at a 40 ft
container's end) by 3.6e-7 m. With ``multiccd`` on (MuJoCo's default) a pair with a mesh geom
gets up to four contacts, its clipped contact polygon pruned to the largest quadrilateral, so
the deepest vertex may be missing; with it off, one GJK/EPA contact per pair (its penetration).
(The model tests have their own copy with the covered-surface filter,
tests/models/compound/mujoco_compound.py: models tests may not import training.)
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart


def _floats(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _geoms(name: str, parts) -> tuple[list[str], list[str]]:
    """(geom elements, mesh assets) of one body's parts."""
    geoms, meshes = [], []
    for k, part in enumerate(parts):
        common = f'name="{name}{k}" margin="0" gap="0" contype="1" conaffinity="1"'
        if isinstance(part, BoxPart):
            geoms.append(f'<geom {common} type="box" size="{_floats(0.5 * np.asarray(part.size))}"'
                         f' pos="{_floats(part.centre)}"/>')
            continue
        vertices = hull_of(part).vertices
        centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        meshes.append(f'<mesh name="{name}m{k}" vertex="{_floats((vertices - centre).ravel())}"/>')
        geoms.append(f'<geom {common} type="mesh" mesh="{name}m{k}" pos="{_floats(centre)}"/>')
    return geoms, meshes


def mujoco_model(parts_a, parts_b, multiccd: bool = True):
    """(MjModel, MjData) of A (qpos 0-6) and B (qpos 7-13), free bodies; ``multiccd`` False
    disables MuJoCo's multi-contact (one contact per geom pair)."""
    import mujoco

    bodies, meshes = [], []
    for name, parts in (("a", parts_a), ("b", parts_b)):
        geoms, assets = _geoms(name, parts)
        meshes += assets
        bodies.append(f'<body name="{name}"><freejoint/>{"".join(geoms)}</body>')
    flag = "" if multiccd else '<flag multiccd="disable"/>'
    xml = (f'<mujoco><option gravity="0 0 0">{flag}</option><asset>' + "".join(meshes)
           + "</asset><worldbody>" + "".join(bodies) + "</worldbody></mujoco>")
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def part_pairs(data, count_a: int) -> dict:
    """``{(part_a, part_b): (depth (m), normal (3,))}`` of the current contacts, the deepest
    per pair."""
    contact = data.contact
    return pairs_of(contact.frame, contact.dist, contact.geom, count_a)


def pairs_of(frame, dist, geom, count_a: int) -> dict:
    """:func:`part_pairs` of copied contact arrays: ``frame`` (k, 9), ``dist`` (k,), ``geom``
    (k, 2) (A's geoms first, ``count_a`` of them)."""
    pairs: dict = {}
    for c in range(len(dist)):
        g1, g2 = int(geom[c][0]), int(geom[c][1])
        normal = np.array(frame[c][0:3])
        if g1 >= count_a:
            g1, g2, normal = g2, g1, -normal
        key, depth = (g1, g2 - count_a), -float(dist[c])
        if key not in pairs or depth > pairs[key][0]:
            pairs[key] = (depth, normal)
    return pairs
