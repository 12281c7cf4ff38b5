"""MuJoCo 4 on a frame's world, called the way a simulator calls it from Python: the model built
once, then per frame the free bodies' poses written into ``qpos``, ``mj_kinematics``,
``mj_collision``, and the contacts copied into NumPy arrays.

The world (:func:`world_model`): one MuJoCo body per frame body, one geom per part (a box geom
for a box part, a mesh geom of the hull's vertices, given about their bounding box's centre,
for a convex part: MuJoCo keeps mesh vertices as float32), every geom ``contype = conaffinity =
1``, margin 0 (the frame's margin), the parent filter off; the bodies the frame marks static
are welded to the world body at their pose (MuJoCo then skips the pairs among them, as the
frame does), the others on free joints. Gravity 0. ``multiccd`` is off by default, as in
``impactnet bench speed`` (one GJK/EPA contact per geom pair with a mesh; MuJoCo's default
adds up to four polygon contacts per such pair, at a cost). The arena holds :data:`ARENA`.

The timed region (:func:`frame_call`) is the simulator's step: qpos in, contacts' ``pos``
(k, 3), ``frame`` (k, 9), ``dist`` (k,) and ``geom`` (k, 2) out. (The model tests have their
own copy of the world, tests/models/frame/mujoco_world.py, which checks the pairs it finds
against the frame's: models tests may not import training.)
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of
from impactnet.models.compound.parts import BoxPart

#: MuJoCo's arena (contacts and constraint buffers): a 209-body detail-2 yard makes ~6,000
#: contacts with multiccd on.
ARENA = "256M"


def _floats(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _shape_geoms(index: int, shape) -> tuple[str, list[str]]:
    """(geom elements, mesh assets) of shape ``index``: one geom per part."""
    geoms, meshes = [], []
    common = 'margin="0" gap="0" contype="1" conaffinity="1"'
    for k, part in enumerate(shape.parts):
        if isinstance(part, BoxPart):
            geoms.append(f'<geom type="box" size="{_floats(0.5 * np.asarray(part.size))}" '
                         f'pos="{_floats(part.centre)}" {common}/>')
            continue
        vertices = hull_of(part).vertices
        centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        name = f"s{index}p{k}"
        meshes.append(f'<mesh name="{name}" vertex="{_floats(vertices - centre)}"/>')
        geoms.append(f'<geom type="mesh" mesh="{name}" pos="{_floats(centre)}" {common}/>')
    return "".join(geoms), meshes


def world_xml(bodies, multiccd: bool = False) -> str:
    """The MJCF of a :class:`~impactnet.models.frame.Bodies` (module docstring): body ``b{i}``
    is the frame's body ``i`` (MuJoCo body id ``i + 1``)."""
    geoms, meshes = [], []
    for k, shape in enumerate(bodies.shapes):
        elements, assets = _shape_geoms(k, shape)
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
    flags = 'filterparent="disable"' + ("" if multiccd else ' multiccd="disable"')
    return (f'<mujoco model="impactnet frame"><option gravity="0 0 0"><flag {flags}/></option>'
            f'<size memory="{ARENA}"/><asset>{"".join(meshes)}</asset>'
            f'<worldbody>{"".join(out)}</worldbody></mujoco>')


def world_model(bodies, multiccd: bool = False):
    """(MjModel, MjData, free (m,) frame indices of the bodies on free joints, in qpos
    order)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(world_xml(bodies, multiccd))
    return model, mujoco.MjData(model), np.flatnonzero(~np.asarray(bodies.static))


def frame_call(model, data, free: np.ndarray):
    """``call(position (n, 3), quaternion (n, 4)) -> (pos, frame, dist, geom)``: one frame
    (module docstring); the poses of every frame body are given, the free ones written."""
    import mujoco

    qpos, kinematics, collision = data.qpos, mujoco.mj_kinematics, mujoco.mj_collision
    full = mujoco.mjtWarning.mjWARN_CONTACTFULL

    def call(position, quaternion):
        qpos[:] = np.concatenate([position[free], quaternion[free]], axis=1).reshape(-1)
        kinematics(model, data)
        collision(model, data)
        contact = data.contact
        return (np.array(contact.pos), np.array(contact.frame), np.array(contact.dist),
                np.array(contact.geom))

    def checked(position, quaternion):
        out = call(position, quaternion)
        if data.warning[full].number:
            raise RuntimeError("MuJoCo's contact buffer is full: raise ARENA")
        return out

    call.checked = checked
    return call


def body_pairs_of(model, geom: np.ndarray) -> set[tuple[int, int]]:
    """The frame-index pairs ``(i, j)``, ``i < j``, of contacts' geom pairs ``geom`` (k, 2)."""
    body_of = model.geom_bodyid - 1
    i, j = body_of[geom[:, 0]], body_of[geom[:, 1]]
    return {(int(a), int(b)) for a, b in zip(np.minimum(i, j), np.maximum(i, j))}
