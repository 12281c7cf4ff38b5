"""Test helper: MuJoCo's box-box collider as an independent reference, in impactnet terms.

Not a test module. The wrapper lives in :mod:`impactnet.training.bench.accuracy.mujoco_reference` so
that ``impactnet bench`` (its "vs MuJoCo" column) and the tests share it; the conventions found for
MuJoCo 4.0 (half-extents, (w, x, y, z) quaternions, ``frame[0:3]`` from geom 0 = A to geom
1 = B, ``dist < 0`` when penetrating, the whole clipped incident face as up to 8 contacts, the
face preference within ~8.1 deg and 5 %) are written down there and re-checked in
``tests/training/bench/test_exact_vs_mujoco.py``. :func:`mujoco_box_box` returns per pose MuJoCo's
contact set (positions, depths ``-dist``, count), its normal oriented from A towards B, the
deepest contact's depth and the depth-weighted centroid of the contact positions.

This module adds what the tests need to explain a disagreement: the overlap of two boxes along
any direction (:func:`overlap_along`), whether the incident box's deepest vertex lies over the
reference face (:func:`deepest_vertex_inside`), and the classes of disagreement
(:func:`disagreement_classes`).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from impactnet.training.bench.accuracy.cop_frame import reference_frame
from impactnet.training.bench.accuracy.mujoco_reference import (
    MAX_CONTACTS,
    MujocoBoxBox,
    mujoco_box_box,
)
from impactnet.training.bench.accuracy.vs_mujoco import (
    FACE_AXIS_RAD,
    NORMAL_TOL_DEG,
    angle_deg,
)
from tests.models.box.overlap_volume import overlap_along

__all__ = ["MAX_CONTACTS", "MujocoBoxBox", "mujoco_box_box", "overlap_along",
           "deepest_vertex_inside", "disagreement_classes", "depth_excess_explained",
           "axis_change_bound"]

#: Depth agreement (x pair scale, metres): the same overlap computed by two float64 formulas
#: differs by a few ulps of the pair's size, amplified by 1 / sin(edge angle) >= 1 / sin(1 deg)
#: for edge axes: ~1e-14 of the scale.
DEPTH_ATOL_REL = 1e-12
#: Two normals this close (degrees) are the same axis computed twice (rounding: ~1e-12 deg).
SAME_AXIS_DEG = 1e-6
#: MuJoCo's face preference (engine_collision_box.c): a winning edge axis whose |cosine| with the
#: best face axis exceeds 0.99 is replaced by that face unless it is shallower by 5 % of the
#: face's depth.
MUJOCO_FACE_COSINE, MUJOCO_FACE_MARGIN = 0.99, 0.05
#: An edge axis of ours closer than this (radians) to the least-overlap face's normal leans on
#: that face: there docs/design.md's tie rule must answer the face (the largest stacking tilt of
#: issue #11, 1e-2 rad, is such a lean), and MuJoCo's face preference does not excuse an edge
#: answer. Farther out, up to MuJoCo's ~8.1 deg, its preferred face and our shallower edge pair
#: are both right.
FACE_LEAN_RAD = 1e-2
#: Two axes whose overlaps differ by less than this (x the sum of both boxes' largest
#: half-extents, the scale of an overlap's rounding) are equally deep: a tie (docs/design.md). Far
#: above rounding (1e-16), far below what a simulator resolves (1 nm on 1 m).
EQUAL_DEPTH_REL = 1e-9
#: MuJoCo reports a contact down to a separation of 1e-13 x the summed half-sizes; a contact
#: this shallow (x pair scale) is touching, and either answer (contact or not) is right.
TOUCHING_REL = 1e-12

#: Disagreement classes (:func:`disagreement_classes`).
AGREE = "agree"  # normal within 1 deg and point within 2 % (or MuJoCo finds no contact)
TOUCHING = "touching"  # contact flags differ at a depth within TOUCHING_REL
MUJOCO_FACE_PREFERENCE = "MuJoCo prefers a face"  # MuJoCo's documented 5 % bias; ours shallower
EQUAL_DEPTH = "equal depth"  # another axis, equally deep; not our edge pair against a face
UNEXPLAINED = "unexplained"
_KEYS = ("size_a", "position_a", "quaternion_a", "size_b", "position_b", "quaternion_b")


def least_face_alignment(normal, args) -> np.ndarray:
    """Angle (radians, (n,)) between ``normal`` (n, 3) and the normal of the face axis of least
    overlap, of A or B: the one face docs/design.md's tie rule (rule 1) lets a leaning cross axis
    compete as. Overlaps by :func:`overlap_along`, the angle in the cross-product form."""
    quaternions = (args[2], args[5])
    axes = np.concatenate([Rotation.from_quat(q, scalar_first=True).as_matrix()
                           for q in quaternions], axis=2)  # (n, 3, 6): the face normals
    overlap = np.stack([overlap_along(np.ascontiguousarray(axes[:, :, k]), args)
                        for k in range(6)], axis=1)
    rows = np.arange(len(normal))
    face = axes[rows, :, overlap.argmin(axis=1)]
    cosine = np.abs(np.einsum("ni,ni->n", face, normal))
    return np.arctan2(np.linalg.norm(np.cross(normal, face), axis=1), cosine)


def deepest_vertex_inside(args, normal, slack_rel: float = 1e-9) -> np.ndarray:
    """(n,) bool: the incident box's deepest vertex (along the reference face's inward normal)
    projects onto the reference face (the face best aligned with ``normal``), within
    ``slack_rel`` x the face's half-extents. Where it does not, a clipped manifold's deepest
    point is shallower than the axis overlap."""
    _, _, t, rot, half_i, half_r, axis, sign, _ = reference_frame(*args, normal)
    rows = np.arange(len(t))
    toward = -sign[:, None] * rot[rows, axis, :]  # the reference's inward normal, incident frame
    corner = np.where(toward >= 0.0, half_i, -half_i)  # support point along it
    vertex = t + np.einsum("nij,nj->ni", rot, corner)
    inside = np.ones(len(t), bool)
    for offset in (1, 2):
        c = (axis + offset) % 3
        inside &= np.abs(vertex[rows, c]) <= half_r[rows, c] * (1.0 + slack_rel)
    return inside


def disagreement_classes(args, ours, reference, errors) -> np.ndarray:
    """The class of each row (see the class constants), shape (n,), dtype object.

    Parameters
    ----------
    args : tuple of ndarray
        The six pose arrays.
    ours : impactnet.models.contacts.Contacts
        The exact solver's answers.
    reference : impactnet.training.bench.accuracy.vs_mujoco.Reference
    errors : dict
        ``impactnet.training.bench.accuracy.vs_mujoco.mujoco_row_errors`` of ours against
        ``reference``.

    Classes, first match wins: AGREE (within the targets, or neither finds a contact);
    TOUCHING (the flags differ, the contact is within TOUCHING_REL deep); MUJOCO_FACE_PREFERENCE
    (MuJoCo answered a face axis, ours an edge pair farther than FACE_LEAN_RAD from the normal
    of the least-overlap face, the one rule 1 of the tie rule compares it with, whose overlap
    is the smaller, with MuJoCo's face within its cosine 0.99 and 5 %);
    EQUAL_DEPTH (ours and MuJoCo's normals are more than the normal target apart and equally
    deep: a tie, where either contact is right, except an edge pair of ours against a face of
    MuJoCo's: docs/design.md's tie rule prefers the face); UNEXPLAINED otherwise. A point that
    differs at the same normal is never explained. (Inside the face band, where MuJoCo answers an
    edge axis and docs/design.md's tie rule prefers the face, both points are references:
    ``impactnet.training.bench.accuracy.vs_mujoco``; such rows are AGREE when either matches.)
    """
    n = len(ours.depth)
    scale = reference.scale
    classes = np.full(n, UNEXPLAINED, dtype=object)
    mj = reference.mujoco
    along_mj = overlap_along(np.where(mj.colliding[:, None], mj.normal, [[0.0, 0.0, 1.0]]),
                             args)
    along_ours = overlap_along(np.where(ours.colliding[:, None], ours.normal, [[0, 0, 1.0]]),
                               args)
    angle = angle_deg(ours.normal, mj.normal)
    atol = DEPTH_ATOL_REL * scale
    flags_differ = ours.colliding != mj.colliding
    shallow = np.where(mj.colliding, mj.depth, ours.depth) <= TOUCHING_REL * scale
    mj_face = reference.face_angle <= FACE_AXIS_RAD
    ours_edge = ours.contact_type_code == 3  # impactnet.models.contacts.EDGE_EDGE
    leaning = least_face_alignment(ours.normal, args) <= FACE_LEAN_RAD
    preference = (mj_face & ours_edge & ~leaning & (along_ours <= along_mj + atol)
                  & ((1.0 - MUJOCO_FACE_MARGIN) * along_mj <= along_ours + atol)
                  & (np.cos(np.radians(angle)) >= MUJOCO_FACE_COSINE))
    size = 0.5 * (np.asarray(args[0]).max(axis=1) + np.asarray(args[3]).max(axis=1))
    equal = ((np.abs(along_ours - along_mj) <= EQUAL_DEPTH_REL * size)
             & (angle > NORMAL_TOL_DEG) & ~(ours_edge & mj_face))
    for label, rows in ((EQUAL_DEPTH, equal), (MUJOCO_FACE_PREFERENCE, preference),
                        (TOUCHING, flags_differ & shallow),
                        (AGREE, errors["within"] | ~(mj.colliding | ours.colliding))):
        classes[rows] = label  # later labels overwrite earlier ones: AGREE wins
    return classes


def axis_change_bound(args, normal_a, normal_b) -> np.ndarray:
    """(n,) metres: how much the overlap can change between two unit axes. Support radii and
    the centre offset are Lipschitz in the axis: ``|o(u) - o(v)| <= |u - v| (rho_A + rho_B +
    |t|)``, ``rho`` a box's half-diagonal and ``t`` the offset of the centres."""
    size_a, position_a, _, size_b, position_b, _ = args
    reach = (0.5 * np.linalg.norm(size_a, axis=1) + 0.5 * np.linalg.norm(size_b, axis=1)
             + np.linalg.norm(position_b - position_a, axis=1))
    return np.linalg.norm(normal_a - normal_b, axis=1) * reach


def depth_excess_explained(args, ours, reference) -> np.ndarray:
    """(n,) bool: our depth exceeds the overlap along MuJoCo's normal by no more than allowed.

    Ours is the least overlap unless the tie rule answered a face for a cross axis leaning on
    it; then the excess is bounded by :func:`axis_change_bound` between the two normals. Rows
    without a contact on either side are True.
    """
    mj = reference.mujoco
    both = mj.colliding & ours.colliding
    along = overlap_along(np.where(both[:, None], mj.normal, [[0.0, 0.0, 1.0]]), args)
    bound = axis_change_bound(args, ours.normal, mj.normal)
    return ~both | (ours.depth - along <= DEPTH_ATOL_REL * reference.scale + bound)


def pose_args(poses) -> tuple:
    """The six solver arguments of a pose dict (``impactnet.models.geometry.poses`` layout),
    float64."""
    return tuple(np.ascontiguousarray(poses[k], dtype=np.float64) for k in _KEYS)
