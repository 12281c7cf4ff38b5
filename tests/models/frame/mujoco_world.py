"""Test helper: a frame's bodies as one MuJoCo 4 world, and the pairs of bodies MuJoCo's
``mj_collision`` finds touching (or within the margin).

Not a test module. Each body of a :class:`~impactnet.models.frame.Bodies` becomes one MuJoCo
body holding one geom per part: a box geom (half extents, at the part's centre) for a box part,
a mesh geom of the hull's vertices for a convex part (given about their bounding box's centre,
the geom placed there: MuJoCo keeps mesh vertices as float32, and a coordinate of 6 m would be
rounded by 3.6e-7 m, one of 5 cm by 4e-9 m). With a margin (> 0) a box part is a mesh geom of
its 8 corners too: MuJoCo 4's box-box collider reports no contact for two boxes whose closest
features are edges apart by less than the margin (measured on a yard: a container's top edge
and the spreader's bottom edge 0.435 m apart, no contact even at a margin of 1 m), while its
convex collider (GJK) gives their distance. A body the frame marks static has no joint: it
is welded to the world body at its pose, and MuJoCo then never collides two of them (their
weld body is the same, the world), as the frame skips pairs inside a registered world; every
other body is on a free joint, its pose written into ``qpos``.

Nothing of MuJoCo's may hide a pair the frame reports:

* every geom has ``contype = conaffinity = 1`` (the frame's default filter, every pair);
* the parent filter is disabled (``<flag filterparent="disable"/>``): it would otherwise drop
  the pairs of a body and its parent's weld body (here every body's parent is the world; MuJoCo
  exempts the world from that filter anyway, the flag makes it independent of that rule);
* there is no ``<exclude>`` and no explicit ``<pair>``: MuJoCo's own broadphase (sweep and
  prune over bodies, then the bounding-sphere and box tests of the geoms, all grown by the
  margin) chooses the candidates, and the comparison is what it finds;
* every geom's ``margin`` is half the frame's margin (``gap`` 0): MuJoCo 4 inflates each geom
  by its margin and sums the two geoms' margins (and gaps) into the pair's (its changelog; up
  to 3.x it took the larger one), then reports a geom pair whose distance is below that sum;
  the frame reports a pair whose distance is at most its margin: the comparison leaves out the
  pairs at that boundary (halving is exact in binary, so the sum is the frame's margin);
* geoms of one body never collide in MuJoCo, as the parts of one body never pair in the
  compound oracle;
* GJK/EPA run to ``ccd_tolerance`` 1e-12 and 2,000 iterations (MuJoCo's defaults, 1e-6 m and
  35, would blur the margin's boundary by micrometres on the mesh geoms);
* the arena holds :data:`ARENA` of contacts, and a full contact buffer raises.

Gravity is 0 and only ``mj_kinematics`` and ``mj_collision`` run: the poses are the frame's.
(``impactnet.training.bench.frame.mujoco_world`` is the benchmark's copy: the model tests may
not import training.)
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart
from impactnet.models.frame import Bodies

#: GJK/EPA settings (m, iterations): far beyond MuJoCo's defaults (module docstring).
CCD_TOLERANCE, CCD_ITERATIONS = 1e-12, 2000
#: MuJoCo's arena (its contacts and constraint buffers): a 3 x 3 yard needs far less.
ARENA = "64M"


def _floats(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _shape_geoms(index: int, shape, margin: float) -> tuple[str, list[str]]:
    """(geom elements, mesh assets) of shape ``index``: one geom per part, each inflated by
    half the frame's ``margin`` (m); box parts as box geoms only without a margin (module
    docstring)."""
    geoms, meshes = [], []
    common = f'margin="{0.5 * margin!r}" gap="0" contype="1" conaffinity="1"'
    for k, part in enumerate(shape.parts):
        if isinstance(part, BoxPart) and margin == 0.0:
            geoms.append(f'<geom type="box" size="{_floats(0.5 * np.asarray(part.size))}" '
                         f'pos="{_floats(part.centre)}" {common}/>')
            continue
        vertices = hull_of(part).vertices
        centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        name = f"s{index}p{k}"
        meshes.append(f'<mesh name="{name}" vertex="{_floats(vertices - centre)}"/>')
        geoms.append(f'<geom type="mesh" mesh="{name}" pos="{_floats(centre)}" {common}/>')
    return "".join(geoms), meshes


def world_xml(bodies: Bodies, margin: float) -> str:
    """The MJCF of ``bodies`` (module docstring): body ``b{i}`` is the frame's body ``i``, in
    the frame's order (MuJoCo body id ``i + 1``); static ones placed at their pose."""
    geoms, meshes = [], []
    for k, shape in enumerate(bodies.shapes):
        elements, assets = _shape_geoms(k, shape, margin)
        geoms.append(elements)
        meshes += assets
    out = []
    for i in range(len(bodies)):
        inner = geoms[int(bodies.shape[i])]
        if bodies.static[i]:
            out.append(f'<body name="b{i}" pos="{_floats(bodies.position[i])}" '
                       f'quat="{_floats(bodies.quaternion[i])}">{inner}</body>')
        else:
            out.append(f'<body name="b{i}"><freejoint/>{inner}</body>')
    return (f'<mujoco><option gravity="0 0 0" ccd_tolerance="{CCD_TOLERANCE!r}" '
            f'ccd_iterations="{CCD_ITERATIONS}"><flag filterparent="disable" '
            f'multiccd="disable"/></option><size memory="{ARENA}"/><asset>{"".join(meshes)}'
            f'</asset><worldbody>{"".join(out)}</worldbody></mujoco>')


def world_model(bodies: Bodies, margin: float):
    """(MjModel, MjData) of ``bodies`` with the free bodies' ``qpos`` set to their poses."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(world_xml(bodies, margin))
    data = mujoco.MjData(model)
    for i in np.flatnonzero(~bodies.static):
        address = model.jnt_qposadr[model.body_jntadr[i + 1]]
        data.qpos[address:address + 3] = bodies.position[i]
        data.qpos[address + 3:address + 7] = bodies.quaternion[i]
    return model, data


def touching_pairs(bodies: Bodies, margin: float) -> set[tuple[int, int]]:
    """The pairs ``(i, j)``, ``i < j`` frame indices, of which MuJoCo's ``mj_kinematics`` and
    ``mj_collision`` report at least one contact: two geoms closer than ``margin`` (m)."""
    import mujoco

    model, data = world_model(bodies, margin)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)
    if data.warning[mujoco.mjtWarning.mjWARN_CONTACTFULL].number:
        raise RuntimeError("MuJoCo's contact buffer is full: raise ARENA")
    body_of = model.geom_bodyid - 1  # frame index of each geom (MuJoCo body 0 is the world)
    geoms = np.array(data.contact.geom).reshape(-1, 2)
    i, j = body_of[geoms[:, 0]], body_of[geoms[:, 1]]
    return {(int(a), int(b)) for a, b in zip(np.minimum(i, j), np.maximum(i, j))}
