"""MuJoCo 4 called from Python the way a user must call it to get an answer, and MuJoCo's own C
rate on many box pairs.

One pair or pose per call (:func:`box_pair_call`, :func:`compound_call`): the model and its
data are built once, before any clock starts (a simulator builds its model once); the timed
region of a call is

1. write both free bodies' poses into ``qpos`` (position, then quaternion (w, x, y, z)),
2. ``mj_kinematics``, 3. ``mj_collision``,
4. copy the contacts' ``pos`` (k, 3), ``frame`` (k, 9) and ``dist`` (k,) into new NumPy arrays
   (compound poses also ``geom`` (k, 2): which parts touch).

The box pair model is :func:`impactnet.training.bench.accuracy.mujoco_reference.box_pair_model` (two
free box geoms, margins 0); the compound model is
:func:`impactnet.training.bench.compound.mujoco_model.mujoco_model` with ``multiccd`` off (one geom
per part, meshes for convex parts).

Many pairs (:class:`ExplicitPairs`): one model of :data:`MODEL_PAIRS` box pairs (twice as many
free bodies). Every geom has ``contype = conaffinity = 0`` and the pairs are named in
``<contact><pair>`` elements, so the named pairs are the only candidates (no dynamic pair can
form; the broadphase has nothing to pair). Per block of pairs, untimed: the boxes' half-extents
(``geom_size``, with ``geom_rbound`` and ``geom_aabb``, which MuJoCo's bounding tests read) and
``qpos`` are written and ``mj_kinematics`` is run (timed apart, for the record); then one
``mj_collision`` over the block is timed alone: MuJoCo's C rate, no Python per pair.
"""
from __future__ import annotations

import numpy as np

#: Box pairs of the explicit-pair model: one ``mj_collision`` per this many pairs.
MODEL_PAIRS = 1000
#: The explicit-pair model's arena: room for 8 contacts per pair (MuJoCo's box-box maximum).
ARENA = "32M"


def _pose_call(model, data, geom: bool):
    """The call of one pose on ``model`` (two free bodies: qpos 0-6 and 7-13)."""
    import mujoco

    qpos, kinematics, collision = data.qpos, mujoco.mj_kinematics, mujoco.mj_collision

    def call(position_a, quaternion_a, position_b, quaternion_b):
        qpos[0:3] = position_a
        qpos[3:7] = quaternion_a
        qpos[7:10] = position_b
        qpos[10:14] = quaternion_b
        kinematics(model, data)
        collision(model, data)
        contact = data.contact
        arrays = (np.array(contact.pos), np.array(contact.frame), np.array(contact.dist))
        return arrays + (np.array(contact.geom),) if geom else arrays

    return call


def box_pair_call(size_a, size_b):
    """``call(position_a, quaternion_a, position_b, quaternion_b) -> (pos, frame, dist)``:
    MuJoCo's contacts of one pose of two boxes of full edge lengths ``size_a``, ``size_b``
    (metres), the timed region of the module docstring."""
    from impactnet.training.bench.accuracy.mujoco_reference import box_pair_model

    return _pose_call(*box_pair_model(tuple(0.5 * np.asarray(size_a, np.float64)),
                                      tuple(0.5 * np.asarray(size_b, np.float64))), geom=False)


def compound_call(parts_a, parts_b):
    """``call(position_a, quaternion_a, position_b, quaternion_b) -> (pos, frame, dist,
    geom)``: MuJoCo's contacts of one pose of two compound bodies (module docstring); geoms
    ``0 .. len(parts_a) - 1`` are A's parts, the next ones B's."""
    from impactnet.training.bench.compound.mujoco_model import mujoco_model

    return _pose_call(*mujoco_model(parts_a, parts_b, multiccd=False), geom=True)


def _pairs_xml(pairs: int) -> str:
    """The explicit-pair model: bodies a0, b0, a1, b1, ... (geom 2k is pair k's A, 2k + 1 its
    B), unit boxes until :meth:`ExplicitPairs.place` sizes them."""
    geom = 'type="box" size="1 1 1" margin="0" gap="0" contype="0" conaffinity="0"'
    bodies = "".join(f'<body name="{s}{k}"><freejoint/><geom name="{s}{k}" {geom}/></body>'
                     for k in range(pairs) for s in "ab")
    named = "".join(f'<pair geom1="a{k}" geom2="b{k}" margin="0" gap="0"/>'
                    for k in range(pairs))
    return (f'<mujoco model="impactnet explicit box pairs"><option gravity="0 0 0"/>'
            f'<size memory="{ARENA}"/><worldbody>{bodies}</worldbody>'
            f"<contact>{named}</contact></mujoco>")


class ExplicitPairs:
    """MuJoCo's C rate on box pairs: :data:`MODEL_PAIRS` pairs per ``mj_collision`` (module
    docstring). Building the model takes a second or two; one instance serves every set."""

    def __init__(self, pairs: int = MODEL_PAIRS):
        import mujoco

        self.pairs = pairs
        self.model = mujoco.MjModel.from_xml_string(_pairs_xml(pairs))
        self.data = mujoco.MjData(self.model)
        self._kinematics, self._collision = mujoco.mj_kinematics, mujoco.mj_collision
        self._full = mujoco.mjtWarning.mjWARN_CONTACTFULL

    def place(self, size_a, position_a, quaternion_a, size_b, position_b, quaternion_b):
        """Put ``pairs`` pairs (rows of the six solver arguments) into the model: sizes, bounds
        and ``qpos``; no kinematics yet."""
        m = self.model
        half = np.empty((2 * self.pairs, 3))
        half[0::2], half[1::2] = 0.5 * size_a, 0.5 * size_b
        m.geom_size[:] = half
        m.geom_rbound[:] = np.linalg.norm(half, axis=1)
        m.geom_aabb[:, :3], m.geom_aabb[:, 3:] = 0.0, half
        self.data.qpos[:] = np.concatenate([position_a, quaternion_a, position_b, quaternion_b],
                                           axis=1).reshape(-1)

    def kinematics(self) -> None:
        self._kinematics(self.model, self.data)

    def collision(self) -> None:
        self._collision(self.model, self.data)

    def contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The current contacts: pos (k, 3), frame (k, 9), dist (k,), pair index (k,)."""
        self._check()
        contact = self.data.contact
        return (np.array(contact.pos), np.array(contact.frame), np.array(contact.dist),
                np.array(contact.geom[:, 0]) // 2)

    def blocks(self, args) -> list[tuple[np.ndarray, ...]]:
        """The whole blocks of ``pairs`` rows of the six arguments (a rest is left out)."""
        n = len(args[0]) // self.pairs * self.pairs
        return [tuple(a[s:s + self.pairs] for a in args) for s in range(0, n, self.pairs)]

    def pass_seconds(self, blocks) -> tuple[float, float, int]:
        """Seconds of ``mj_kinematics`` and of ``mj_collision`` over all ``blocks``, each call
        timed alone (placing the pairs untimed, the collector paused), and the contacts found."""
        from impactnet.training.bench.timing import call_times

        kinematics = collision = 0.0
        contacts = 0
        for block in blocks:
            self.place(*block)
            kinematics += call_times([(self.kinematics, ())], 0)[0]
            collision += call_times([(self.collision, ())], 0)[0]
            contacts += int(self.data.ncon)
        self._check()
        return kinematics, collision, contacts

    def _check(self) -> None:
        if self.data.warning[self._full].number:
            raise RuntimeError("MuJoCo's contact buffer is full: raise ARENA")
