"""The exact contact of two convex parts, vectorised over m rows: poses of the same two hulls
(:func:`convex_contacts`), or of several pairs of hulls at once (:func:`stacked_contacts`, each
row naming its hulls in two :class:`~impactnet.models.compound.hull_stack.HullStack`; a row's
answer is the same bits either way).

The convex counterpart of :func:`impactnet.models.box.exact.box_box`, with its conventions
(DESIGN.md): the separating-axis test and tie rule of
:mod:`impactnet.models.compound.convex_sat`, the centre of pressure of
:mod:`impactnet.models.compound.convex_face` for face axes, the midpoint of the edges' closest
points for edge axes. Works in A's body frame (``t = R_A^T (p_B - p_A)``, ``R = R_A^T R_B``),
so far from the origin the answer is the same as at it, and maps the answer to the world.

Answers are :class:`impactnet.models.contacts.Contacts` rows, with two differences from the box
solver's: ``feature_a``/``feature_b`` are hull feature ids (:mod:`impactnet.models.compound.hull`,
int32: a 256-sided twistlock has 1,538 features), and ``axis`` is -1 (a hull has no fixed axis
numbering). A box part's hull keeps the box's feature ids.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.tolerances import FACE_INC_CODES, FACE_REF_CODES
from impactnet.models.compound.convex_face import face_region
from impactnet.models.compound.convex_sat import EDGE, FACE_A, FACE_B, choose_axis, rotate
from impactnet.models.compound.hull import Hull
from impactnet.models.compound.hull_stack import HullStack, stack_hulls
from impactnet.models.contacts import Contacts

#: Work items (pose x table entries) per chunk of poses: keeps each (chunk, ...) array of the
#: separating-axis test within a few tens of MB whatever the hulls' detail.
CHUNK_ITEMS = 2_000_000


def chunk_rows(sa: HullStack, sb: HullStack) -> int:
    """Rows per chunk for these (padded) stacks."""
    a, b = sa.width, sb.width
    per_row = (a["V"] * b["F"] + b["V"] * a["F"] + a["E"] * b["E"] + 3 * (a["T"] + b["T"]))
    return max(1, CHUNK_ITEMS // per_row)


def convex_contacts(hull_a: Hull, hull_b: Hull, position_a, rot_a, position_b,
                    rot_b) -> Contacts:
    """Contacts of m poses of two convex parts.

    Parameters
    ----------
    hull_a, hull_b : Hull
        The parts, each in its body's frame.
    position_a, position_b : ndarray, shape (m, 3)
        The bodies' origins in the world (metres).
    rot_a, rot_b : ndarray, shape (m, 3, 3)
        The bodies' rotations.

    Returns
    -------
    Contacts
        m rows, world frame, normal from A's part towards B's.
    """
    m = len(position_a)
    return stacked_contacts(stack_hulls((hull_a,)), np.zeros(m, np.int64),
                            stack_hulls((hull_b,)), np.zeros(m, np.int64), position_a, rot_a,
                            position_b, rot_b)


def stacked_contacts(stack_a: HullStack, index_a, stack_b: HullStack, index_b, position_a,
                     rot_a, position_b, rot_b) -> Contacts:
    """Contacts of m rows, row i of A's part ``stack_a.hulls[index_a[i]]`` and B's part
    ``stack_b.hulls[index_b[i]]`` (arguments otherwise as :func:`convex_contacts`)."""
    m = len(position_a)
    step = chunk_rows(stack_a, stack_b)
    pieces = [_solve(stack_a, index_a[s:s + step], stack_b, index_b[s:s + step],
                     position_a[s:s + step], rot_a[s:s + step], position_b[s:s + step],
                     rot_b[s:s + step]) for s in range(0, m, step)]
    if len(pieces) == 1:
        return pieces[0]
    return Contacts(**{name: np.concatenate([p.arrays()[name] for p in pieces])
                       for name in pieces[0].arrays()})


def _solve(sa, ia, sb, ib, position_a, rot_a, position_b, rot_b) -> Contacts:
    """One chunk of :func:`stacked_contacts`."""
    ra_t = rot_a.transpose(0, 2, 1)
    t = np.einsum("nij,nj->ni", ra_t, position_b - position_a)
    rot = ra_t @ rot_b
    choice = choose_axis(sa, sb, t, rot, ia, ib)
    out = _empty(sa, ia, sb, ib, t, rot)
    out["normal"] = choice.normal.copy()
    for kind in (FACE_A, FACE_B):
        rows = np.flatnonzero(choice.colliding & (choice.kind == kind))
        if len(rows):
            _face_rows(out, rows, kind, (sa, ia, sb, ib), t, rot, choice)
    rows = np.flatnonzero(choice.colliding & (choice.kind == EDGE))
    if len(rows):
        out["point"][rows] = choice.edge_point[rows]
        out["depth"][rows] = choice.depth[rows]
        out["contact_type_code"][rows] = ct.EDGE_EDGE
        out["feature_a"][rows] = sa.n_faces[ia[rows]] + choice.edge_a[rows]  # edge ids
        out["feature_b"][rows] = sb.n_faces[ib[rows]] + choice.edge_b[rows]
        out["manifold_points"][rows, 0] = choice.edge_point[rows]
        out["manifold_depths"][rows, 0] = choice.depth[rows]
        out["manifold_count"][rows] = 1
    out["colliding"] = choice.colliding
    return _to_world(out, position_a, rot_a)


def _empty(sa, ia, sb, ib, t, rot) -> dict:
    """The answer arrays of m separated rows (point: the midpoint of the hulls' centres)."""
    m = len(t)
    centre_a = sa.centre[ia]
    centre_b = t + rotate(rot, sb.centre[ib][:, None, :])[:, 0]
    return {"depth": np.zeros(m), "point": 0.5 * (centre_a + centre_b),
            "contact_type_code": np.zeros(m, np.int8),
            "feature_a": np.full(m, -1, np.int32), "feature_b": np.full(m, -1, np.int32),
            "axis": np.full(m, -1, np.int8),
            "manifold_points": np.zeros((m, ct.MAX_MANIFOLD_POINTS, 3)),
            "manifold_depths": np.zeros((m, ct.MAX_MANIFOLD_POINTS)),
            "manifold_count": np.zeros(m, np.int8), "pressure": np.zeros(m)}


def rotate_rows(rot: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R_i v_i`` for rotations (m, 3, 3) and vectors (m, 3) or (3,)."""
    return rotate(rot, np.atleast_2d(v))[:, 0] if np.ndim(v) == 1 else np.einsum(
        "nij,nj->ni", rot, v)


def _face_rows(out, rows, kind, stacks, t, rot, choice) -> None:
    """Fill the face-axis rows of one kind (reference face on A or on B); ``stacks`` is
    (stack_a, index_a, stack_b, index_b)."""
    sa, ia, sb, ib = stacks
    t_r, rot_r = t[rows], rot[rows]
    if kind == FACE_A:
        ref, rid, inc, iid, rot_inc = sa, ia[rows], sb, ib[rows], rot_r
        x_inc = t_r[:, None, :] + rotate(rot_r, sb.vertices[iid])
    else:  # B's face: work in B's frame, x' = R^T (x - t)
        ref, rid, inc, iid = sb, ib[rows], sa, ia[rows]
        rot_inc = rot_r.transpose(0, 2, 1)
        x_inc = rotate(rot_inc, sa.vertices[iid]) - rotate_rows(rot_inc, t_r)[:, None, :]
    region = face_region(ref, rid, choice.face[rows], inc, iid, x_inc, rot_inc,
                         choice.depth[rows], choice.scale[rows])
    point, manifold = region.point, region.manifold
    if kind == FACE_B:  # back to A's frame
        point = rotate_rows(rot_r, point) + t_r
        manifold = np.einsum("nij,nkj->nki", rot_r, manifold) + t_r[:, None, :]
        manifold = np.where((np.arange(manifold.shape[1])[None, :]
                             < region.manifold_count[:, None])[:, :, None], manifold, 0.0)
        out["contact_type_code"][rows] = FACE_INC_CODES[region.rank]
        out["feature_a"][rows], out["feature_b"][rows] = region.feature, choice.face[rows]
    else:
        out["contact_type_code"][rows] = FACE_REF_CODES[region.rank]
        out["feature_a"][rows], out["feature_b"][rows] = choice.face[rows], region.feature
    out["point"][rows], out["depth"][rows] = point, region.depth
    out["manifold_points"][rows], out["manifold_depths"][rows] = manifold, region.manifold_depth
    out["manifold_count"][rows] = region.manifold_count
    out["pressure"][rows] = region.pressure


def _to_world(out: dict, position_a, rot_a) -> Contacts:
    """The answer arrays (A's body frame) as world-frame Contacts."""
    count = out["manifold_count"]
    valid = (np.arange(ct.MAX_MANIFOLD_POINTS)[None, :] < count[:, None])[:, :, None]
    manifold = np.einsum("nij,nkj->nki", rot_a, out["manifold_points"]) + position_a[:, None]
    return Contacts(colliding=out["colliding"], normal=rotate_rows(rot_a, out["normal"]),
                    depth=out["depth"], point=rotate_rows(rot_a, out["point"]) + position_a,
                    contact_type_code=out["contact_type_code"], feature_a=out["feature_a"],
                    feature_b=out["feature_b"], axis=out["axis"],
                    manifold_points=np.where(valid, manifold, 0.0),
                    manifold_depths=out["manifold_depths"], manifold_count=count,
                    pressure=out["pressure"])
