"""MuJoCo's box-box collider as an independent reference, in impactnet conventions.

:func:`mujoco_box_box` builds one MuJoCo model per distinct pair of box sizes (two free bodies,
one box geom each), sets the poses row by row through ``qpos``, runs ``mj_kinematics`` and
``mj_collision`` and reads ``mjData.contact``. MuJoCo is a dev / bench dependency: it is
imported when the first model is built, never at module import.

MuJoCo 4.0 conventions, checked empirically on 4.0.0 (cubes of edge 2, A = geom 0, B = geom 1;
the key cases are re-checked in ``tests/training/bench/test_exact_vs_mujoco.py``). The box-box
collider was rewritten after 3.9 ("SAT + polygon clipping + true edge-edge contacts"), so the
dev extra should ask for ``mujoco>=4.0``.
------------------------------------------------------------------------------------------
* Sizes. A box geom's ``size`` is its HALF-extents: ``size_a / 2`` here.
* Quaternions. A free joint's ``qpos`` is (x, y, z, qw, qx, qy, qz): (w, x, y, z) order.
* Collider. Box-box goes to the primitive ``mjc_BoxBox`` (``engine_collision_box.c``), not to
  the general convex (GJK / MPR) path: ``mj_maxContact`` allows it 8 contacts, and every vertex
  of the clipped incident face is returned (a 45 deg yawed stack gives 8 contacts). There is no
  flag to set for the full manifold; ``mjDSBL_MULTICCD`` / ``mjDSBL_NATIVECCD`` do not apply to
  box-box. Margin and gap are set to 0 on both geoms (``margin="0" gap="0"``).
* Normal. ``contact.frame[0:3]`` is one unit normal per pair, pointing from ``contact.geom[0]``
  to ``contact.geom[1]``; MuJoCo keeps geom order (0, 1) for two boxes, so it points from A to
  B, impactnet's convention (B above A: +z; B below A: -z). The code checks the geom order
  anyway and flips the normal if MuJoCo ever swaps the pair.
* Depth. ``contact.dist`` is the signed distance: negative when penetrating. Depth = -dist.
  MuJoCo's separation test has a slack of 1e-13 x the summed half-sizes, so a touching pair may
  report a contact with a tiny positive dist (depth -1e-13 relative).
* Points. Face contacts: each clipped vertex of the incident face, moved to the mid-surface
  (half its depth towards the reference face), ``dist`` measured along the reference normal.
  Edge contacts: one point, the midpoint of the two edges' closest points.
* Axis choice. Least overlap over the 15 axes, with two biases towards face axes: an edge axis
  must beat the best face axis by a relative 1e-6; and a winning edge axis within ~8.1 deg of the
  best face axis (|cos| > 0.99) is replaced by that face unless it is shallower by 5 % of the
  face's depth (ODE's fudge). Where the latter applies, MuJoCo's normal is up to 8.1 deg from
  the least-overlap axis and its depth up to 1 / 0.95 of the least overlap.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

#: Contacts MuJoCo's box-box collider returns at most (``mj_maxContact`` for two boxes).
MAX_CONTACTS = 8
#: Model of two free boxes; sizes are filled in as half-extents (metres), margins are 0.
_XML = """<mujoco model="impactnet box-box reference">
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="a"><freejoint/><geom name="a" type="box" size="{a}" margin="0" gap="0"/></body>
    <body name="b"><freejoint/><geom name="b" type="box" size="{b}" margin="0" gap="0"/></body>
  </worldbody>
</mujoco>"""


@dataclass
class MujocoBoxBox:
    """MuJoCo's answer for N box pairs (world frame, metres, normal from A towards B).

    Attributes
    ----------
    count : ndarray of int, shape (n,)
        Number of contacts (0: separated).
    points : ndarray, shape (n, MAX_CONTACTS, 3)
        Contact positions (MuJoCo's mid-surface points); rows past ``count`` are 0.
    depths : ndarray, shape (n, MAX_CONTACTS)
        Penetration depths ``-dist`` (metres, > 0 penetrating); padding is 0.
    normal : ndarray, shape (n, 3)
        MuJoCo's unit normal oriented from A towards B (shared by a row's contacts); 0 where
        separated.
    depth : ndarray, shape (n,)
        Deepest contact's depth (metres); 0 where separated.
    point : ndarray, shape (n, 3)
        Depth-weighted centroid of the contact positions (weights ``max(depth, 0)``; the plain
        mean when no weight is positive); the midpoint of the centres where separated.
    """

    count: np.ndarray
    points: np.ndarray
    depths: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    point: np.ndarray

    @property
    def colliding(self) -> np.ndarray:
        """(n,) bool: MuJoCo reports at least one contact."""
        return self.count > 0


@lru_cache(maxsize=64)
def box_pair_model(half_a: tuple, half_b: tuple):
    """Compiled model and data of two free boxes (A: geom 0, qpos 0-6; B: geom 1, qpos 7-13)
    for one pair of half-extents (cached: sizes repeat; the data is shared by its callers)."""
    import mujoco

    text = _XML.format(a=" ".join(repr(float(x)) for x in half_a),
                     b=" ".join(repr(float(x)) for x in half_b))
    model = mujoco.MjModel.from_xml_string(text)
    return model, mujoco.MjData(model)


def _rows(x, width: int, n: int) -> np.ndarray:
    """Array-like -> float64 (n, width), broadcasting a single row."""
    array = np.asarray(x, dtype=np.float64).reshape(-1, width)
    return np.broadcast_to(array, (n, width))


def _collide_rows(model, data, qpos: np.ndarray, out: MujocoBoxBox, rows: np.ndarray) -> None:
    """Collide ``rows`` of one size group; ``qpos`` (len(rows), 14); results into ``out``."""
    import mujoco

    for k, row in enumerate(rows):
        data.qpos[:] = qpos[k]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        count = int(data.ncon)
        if count == 0:
            continue
        if count > MAX_CONTACTS:
            raise RuntimeError(f"MuJoCo returned {count} box-box contacts (> {MAX_CONTACTS})")
        contact = data.contact
        first = contact.geom[0, 0] if hasattr(contact, "geom") else contact.geom1[0]
        flip = -1.0 if int(first) != 0 else 1.0  # geom 0 is A
        out.count[row] = count
        out.points[row, :count] = contact.pos[:count]
        out.depths[row, :count] = -contact.dist[:count]
        out.normal[row] = flip * contact.frame[0, 0:3]


def _reduce(out: MujocoBoxBox, position_a: np.ndarray, position_b: np.ndarray) -> None:
    """Fill ``depth`` and ``point`` (deepest depth, depth-weighted centroid) from the contacts."""
    slot = np.arange(MAX_CONTACTS)[None, :] < out.count[:, None]
    out.depth[:] = np.where(out.count > 0, np.where(slot, out.depths, -np.inf).max(axis=1), 0.0)
    weight = np.where(slot, np.maximum(out.depths, 0.0), 0.0)
    plain = weight.sum(axis=1) <= 0.0
    weight[plain] = slot[plain]  # no positive depth: the plain mean of the contacts
    total = weight.sum(axis=1)
    centroid = np.einsum("nk,nkc->nc", weight, out.points) / np.where(total > 0, total, 1.0)[
        :, None]
    out.point[:] = np.where((out.count > 0)[:, None], centroid, 0.5 * (position_a + position_b))


def mujoco_box_box(size_a, position_a, quaternion_a, size_b, position_b,
                   quaternion_b) -> MujocoBoxBox:
    """Collide N box pairs with MuJoCo's box-box collider, one row at a time.

    Parameters
    ----------
    size_a, size_b : array_like, shape (3,) or (n, 3)
        Full edge lengths (metres); MuJoCo gets half of them.
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Box centres in the world frame (metres).
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Orientations (w, x, y, z), any norm > 0 (normalised here).

    Returns
    -------
    MujocoBoxBox
        N rows, in impactnet conventions (see the module docstring).

    Raises
    ------
    ImportError
        MuJoCo is not installed.
    """
    values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
    n = max(np.asarray(v, dtype=np.float64).reshape(-1, w).shape[0]
            for v, w in zip(values, (3, 3, 4, 3, 3, 4)))
    sa, pa, qa, sb, pb, qb = (_rows(v, w, n) for v, w in zip(values, (3, 3, 4, 3, 3, 4)))
    qa = qa / np.linalg.norm(qa, axis=1, keepdims=True)
    qb = qb / np.linalg.norm(qb, axis=1, keepdims=True)
    qpos = np.concatenate([pa, qa, pb, qb], axis=1)  # two free joints: (pos, quat) each
    out = MujocoBoxBox(np.zeros(n, np.int64), np.zeros((n, MAX_CONTACTS, 3)),
                       np.zeros((n, MAX_CONTACTS)), np.zeros((n, 3)), np.zeros(n),
                       np.zeros((n, 3)))
    sizes = np.concatenate([sa, sb], axis=1)
    groups, inverse = np.unique(sizes, axis=0, return_inverse=True)
    for g, group in enumerate(groups):
        rows = np.flatnonzero(inverse.reshape(-1) == g)
        model, data = box_pair_model(tuple(0.5 * group[:3]), tuple(0.5 * group[3:]))
        _collide_rows(model, data, qpos[rows], out, rows)
    _reduce(out, pa, pb)
    return out
