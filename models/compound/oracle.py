"""The exact contact oracle of two compound bodies made of box and convex parts, vectorised
over poses (issue #20, step 2).

Stages, for N poses of one pair of bodies (A with ``P_a`` parts, B with ``P_b``):

1. Placement: every part's bounds (a box part itself, a convex part's axis-aligned bounding
   box in the body frame) centred in the world, ``p + R c`` (parts are not rotated in their
   body's frame, so a part's orientation is its body's), shape (n, P, 3).
2. Broadphase: the part pairs whose bounds are not separated along any of the six face axes
   of the two bounds (the box solver's face tests without its edge axes, so nothing that
   touches is culled), over all ``n x P_a x P_b`` at once; the survivors as
   (pose, part_a, part_b) rows, pose-major.
3. Narrowphase: one call of the box solver (:func:`impactnet.models.box.exact.box_box`) on all
   surviving pairs of box parts, one call of the convex solver
   (:func:`impactnet.models.compound.convex_contact.stacked_contacts`) per pair of size classes
   of the parts (:func:`impactnet.models.compound.hull_stack.size_classes`) on the pairs with a
   convex part; the conventions hold for every part contact (normal from A's part towards B's,
   the centre of pressure as the point, DESIGN.md). Features are int32: box ids for box
   parts, hull ids for convex ones.
4. Filter: a part contact whose touched surface one body covers with its other parts is
   dropped (a container's roof under its own top castings): all of its manifold points, moved
   from the mid-surface back onto that body's part, inside other parts of that body (deeper
   than :data:`INSIDE_MARGIN_REL` of their size). A contact that reaches out of the covering
   parts stays.

The answer is ragged: :class:`PartContacts` lists the part contacts of all poses, pose-major,
with ``offsets`` (n + 1,) delimiting each pose's rows. The body-level summary of DESIGN.md (a
cluster around the deepest contact, weighted by the integral of the depth) is the next step.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.box.exact import box_box
from impactnet.models.compound.body_table import body_table
from impactnet.models.compound.broadphase import broadphase
from impactnet.models.compound.convex_contact import chunk_rows, stacked_contacts
from impactnet.models.compound.convex_sat import choose_axis
from impactnet.models.contacts import Contacts
from impactnet.models.geometry.rotations import quaternion_to_matrix, validate_quaternion

#: A part contact's point counts as inside another part of its body when it lies that far
#: (x the other part's smallest edge) inside all of its faces: far above round-off, far below
#: any part's thickness.
INSIDE_MARGIN_REL = 1e-9
#: Poses per block of the oracle (a block's arrays stay in the CPU caches; 1e5 poses in one
#: block cost twice as much per pose as in blocks of a few thousand, measured on 40 ft
#: stacking).
ORACLE_CHUNK = 4096
#: Up to this many surviving part pairs are solved one by one on the plain-float path (the
#: batch path's fixed cost, ~1 ms, is worth it only for more).
FEW_PAIRS = 12


@dataclass(frozen=True)
class PartContacts:
    """The part contacts of N poses of a pair of compound bodies, pose-major (k rows)."""

    pose: np.ndarray  # (k,) int64, the pose of each contact
    part_a: np.ndarray  # (k,) int16, index into body A's parts
    part_b: np.ndarray  # (k,) int16, index into body B's parts
    contacts: Contacts  # k rows: the box solver's answer for each part pair
    offsets: np.ndarray  # (n + 1,) int64: pose i's contacts are rows offsets[i]:offsets[i+1]

    def of_pose(self, i: int) -> slice:
        """The rows of pose ``i``."""
        return slice(int(self.offsets[i]), int(self.offsets[i + 1]))


def _poses(position, quaternion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    position = np.atleast_2d(np.asarray(position, np.float64))
    quaternion = validate_quaternion(np.atleast_2d(np.asarray(quaternion, np.float64)))
    return position, quaternion, quaternion_to_matrix(quaternion)


def compound_contacts(parts_a, position_a, quaternion_a, parts_b, position_b,
                      quaternion_b) -> PartContacts:
    """Part contacts of N poses of body A (``parts_a``) against body B (``parts_b``).

    Parameters
    ----------
    parts_a, parts_b : tuple of BoxPart or ConvexPart
        Validated parts (:func:`impactnet.models.compound.parts.validate_parts`), body frame.
    position_a, position_b : array_like, shape (3,) or (n, 3)
        Body origins in the world (metres).
    quaternion_a, quaternion_b : array_like, shape (4,) or (n, 4)
        Body orientations (w, x, y, z), normalised here.

    Returns
    -------
    PartContacts
        The colliding part pairs of every pose, after the filter of internal contacts.
    """
    table_a, table_b = body_table(parts_a), body_table(parts_b)
    pos_a, q_a, rot_a = _poses(position_a, quaternion_a)
    pos_b, q_b, rot_b = _poses(position_b, quaternion_b)
    n = max(len(pos_a), len(pos_b))
    pos_a, pos_b = np.broadcast_to(pos_a, (n, 3)), np.broadcast_to(pos_b, (n, 3))
    q_a, q_b = np.broadcast_to(q_a, (n, 4)), np.broadcast_to(q_b, (n, 4))
    rot_a, rot_b = np.broadcast_to(rot_a, (n, 3, 3)), np.broadcast_to(rot_b, (n, 3, 3))
    if n > ORACLE_CHUNK:  # blocks of poses: the working set stays in the CPU caches
        return joined([_solve((pos_a[s:s + ORACLE_CHUNK], q_a[s:s + ORACLE_CHUNK],
                                rot_a[s:s + ORACLE_CHUNK], table_a),
                               (pos_b[s:s + ORACLE_CHUNK], q_b[s:s + ORACLE_CHUNK],
                                rot_b[s:s + ORACLE_CHUNK], table_b))
                        for s in range(0, n, ORACLE_CHUNK)])
    return _solve((pos_a, q_a, rot_a, table_a), (pos_b, q_b, rot_b, table_b))


def compound_touching(parts_a, position_a, quaternion_a, parts_b, position_b,
                      quaternion_b) -> np.ndarray:
    """(n,) bool: whether any part of B touches any part of A, pose by pose (arguments as
    :func:`compound_contacts`).

    The separating-axis test alone, on the broadphase's survivors (box parts through their
    box hulls): no contact geometry and no filter of covered surfaces, a fraction of the
    oracle's cost. A covered surface lies inside another part of its body, which the other
    body's part then overlaps too, so a pose touches here iff the oracle finds a contact
    (within the contact tolerance). Data generation's first-contact search asks only this.
    """
    table_a, table_b = body_table(parts_a), body_table(parts_b)
    pos_a, _, rot_a = _poses(position_a, quaternion_a)
    pos_b, _, rot_b = _poses(position_b, quaternion_b)
    n = max(len(pos_a), len(pos_b))
    pos_a, pos_b = np.broadcast_to(pos_a, (n, 3)), np.broadcast_to(pos_b, (n, 3))
    rot_a, rot_b = np.broadcast_to(rot_a, (n, 3, 3)), np.broadcast_to(rot_b, (n, 3, 3))
    pose, i, j = broadphase(table_a, table_b, pos_b - pos_a, rot_a, rot_b)
    classes_a, classes_b = table_a.classes, table_b.classes
    ra_t = rot_a[pose].transpose(0, 2, 1)
    t = np.einsum("kij,kj->ki", ra_t, (pos_b - pos_a)[pose])
    rot = ra_t @ rot_b[pose]
    pair_class = classes_a.klass[i] * len(classes_b.stacks) + classes_b.klass[j]
    touching = np.zeros(n, bool)
    for key in np.unique(pair_class):
        rows = np.flatnonzero(pair_class == key)
        stack_a = classes_a.stacks[key // len(classes_b.stacks)]
        stack_b = classes_b.stacks[key % len(classes_b.stacks)]
        step = chunk_rows(stack_a, stack_b)
        for s in range(0, len(rows), step):
            block = rows[s:s + step]
            choice = choose_axis(stack_a, stack_b, t[block], rot[block],
                                 classes_a.slot[i[block]], classes_b.slot[j[block]])
            touching[pose[block[choice.colliding]]] = True
    return touching


def _solve(body_a, body_b) -> PartContacts:
    """:func:`compound_contacts` on one block of poses (bodies as (positions, quaternions,
    rotations, table))."""
    pos_a, _, rot_a, table_a = body_a
    pos_b, _, rot_b, table_b = body_b
    pose, i, j = broadphase(table_a, table_b, pos_b - pos_a, rot_a, rot_b)
    return _contacts_of(pose, i, j, body_a, body_b)


def part_pair_contacts(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b,
                       pose, part_a, part_b) -> PartContacts:
    """The oracle's narrowphase and filter on chosen part pairs only, no broadphase: the exact
    part-pair expert of the learned path (issue #21), which names the candidates.

    Parameters
    ----------
    parts_a, parts_b, position_a, quaternion_a, position_b, quaternion_b
        As :func:`compound_contacts` (n poses).
    pose, part_a, part_b : array_like, shape (k,)
        The candidate part pairs: pose index, A's part, B's part; sorted by pose.

    Returns
    -------
    PartContacts
        The candidates that touch (after the filter of covered surfaces), pose-major, with
        ``offsets`` over the n poses: the oracle's answer whenever the candidates include every
        touching part pair.
    """
    table_a, table_b = body_table(parts_a), body_table(parts_b)
    pos_a, q_a, rot_a = _poses(position_a, quaternion_a)
    pos_b, q_b, rot_b = _poses(position_b, quaternion_b)
    n = max(len(pos_a), len(pos_b))
    body_a = (np.broadcast_to(pos_a, (n, 3)), np.broadcast_to(q_a, (n, 4)),
              np.broadcast_to(rot_a, (n, 3, 3)), table_a)
    body_b = (np.broadcast_to(pos_b, (n, 3)), np.broadcast_to(q_b, (n, 4)),
              np.broadcast_to(rot_b, (n, 3, 3)), table_b)
    pose = np.asarray(pose, np.int64)
    if len(pose) > 1 and (np.diff(pose) < 0).any():
        raise ValueError("part_pair_contacts: candidates must be sorted by pose")
    return _contacts_of(pose, np.asarray(part_a, np.int64), np.asarray(part_b, np.int64),
                        body_a, body_b)


def _contacts_of(pose, i, j, body_a, body_b) -> PartContacts:
    """Narrowphase and filter of the part pairs (pose, i, j) (pose-major) of n poses."""
    n = len(body_a[0])
    found = _narrowphase(pose, i, j, body_a, body_b)
    rows = np.flatnonzero(found.colliding)
    rows = rows[~_hidden(found, rows, pose, i, j, body_a, body_b)]
    pose = pose[rows]
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(pose, minlength=n), out=offsets[1:])
    return PartContacts(pose.astype(np.int64), i[rows].astype(np.int16),
                        j[rows].astype(np.int16), found.take(rows), offsets)


def joined(blocks: list[PartContacts]) -> PartContacts:
    """Blocks of consecutive poses as one PartContacts."""
    shift = np.cumsum([0] + [len(b.offsets) - 1 for b in blocks[:-1]])
    start = np.cumsum([0] + [int(b.offsets[-1]) for b in blocks[:-1]])
    contacts = _in_order([(np.arange(int(b.offsets[-1])) + s, b.contacts)
                          for b, s in zip(blocks, start)], int(sum(b.offsets[-1] for b in blocks)))
    return PartContacts(np.concatenate([b.pose + d for b, d in zip(blocks, shift)]),
                        np.concatenate([b.part_a for b in blocks]),
                        np.concatenate([b.part_b for b in blocks]), contacts,
                        np.concatenate([[0]] + [b.offsets[1:] + s for b, s in zip(blocks, start)]))


def _narrowphase(pose, i, j, body_a, body_b) -> Contacts:
    """The exact contact of every surviving part pair: box pairs through the box solver in one
    call, the others through the convex solver, one call per pair of the parts' size classes;
    the rows in the order of the survivors."""
    pos_a, q_a, rot_a, table_a = body_a
    pos_b, q_b, rot_b, table_b = body_b
    both = table_a.is_box[i] & table_b.is_box[j]
    rows = np.flatnonzero(both)
    at, ia, jb = pose[rows], i[rows], j[rows]
    # Box parts are solved about A's origin (centres relative to p_A, then the answer moved
    # back): a body at the position limit has parts beyond it, and the box solver's domain
    # is the body's, not the part's.
    centre_a = np.einsum("kij,kj->ki", rot_a[at], table_a.centre[ia])
    centre_b = (pos_b[at] - pos_a[at]) + np.einsum("kij,kj->ki", rot_b[at], table_b.centre[jb])
    found = _box_pairs(table_a.size[ia], centre_a, q_a[at], table_b.size[jb], centre_b,
                       q_b[at])
    found.point += pos_a[at]
    found.manifold_points += np.where(
        (np.arange(found.manifold_points.shape[1])[None, :]
         < found.manifold_count[:, None])[:, :, None], pos_a[at][:, None, :], 0.0)
    pieces = [(rows, found)]
    others = np.flatnonzero(~both)
    classes_a, classes_b = table_a.classes, table_b.classes
    ia, jb = i[others], j[others]
    pair_class = classes_a.klass[ia] * len(classes_b.stacks) + classes_b.klass[jb]
    for key in np.unique(pair_class):  # one call per pair of size classes
        take = pair_class == key
        rows, at = others[take], pose[others[take]]
        pieces.append((rows, stacked_contacts(
            classes_a.stacks[key // len(classes_b.stacks)], classes_a.slot[ia[take]],
            classes_b.stacks[key % len(classes_b.stacks)], classes_b.slot[jb[take]],
            pos_a[at], rot_a[at], pos_b[at], rot_b[at])))
    return _in_order(pieces, len(pose))


def _in_order(pieces, k: int) -> Contacts:
    """The pieces' rows (each ``(rows, Contacts)``) as one Contacts of k rows, features int32."""
    if len(pieces) == 1:
        found = pieces[0][1]
        found.feature_a = found.feature_a.astype(np.int32)
        found.feature_b = found.feature_b.astype(np.int32)
        return found
    order = np.concatenate([rows for rows, _ in pieces])
    where = np.empty(k, np.int64)
    where[order] = np.arange(k)
    return concatenated([found for _, found in pieces], where)


def concatenated(pieces: list[Contacts], take: np.ndarray) -> Contacts:
    """The rows of ``pieces`` one after another, then rows ``take`` of that; features int32."""
    arrays = [found.arrays() for found in pieces]
    merged = {}
    for name in arrays[0]:
        column = np.concatenate([a[name] for a in arrays])
        if name in ("feature_a", "feature_b"):
            column = column.astype(np.int32)
        merged[name] = column[take]
    return Contacts(**merged)


def _box_pairs(*columns) -> Contacts:
    """The box solver on box part pairs: one vectorised call, or, for the few pairs of a
    single pose, one call per pair on the solver's plain-float path (bit-identical to the
    batch, and free of the batch's fixed NumPy cost)."""
    k = len(columns[0])
    if k == 0 or k > FEW_PAIRS:
        return box_box(*columns)
    rows = [box_box(*(c[r] for c in columns)).arrays() for r in range(k)]
    return Contacts(**{name: np.concatenate([row[name] for row in rows]) for name in rows[0]})


def _hidden(found: Contacts, rows, pose, i, j, body_a, body_b) -> np.ndarray:
    """(len(rows),) bool: the contact lies on a surface its body covers with other parts: all
    of A's surface points of the manifold (each mid-surface point moved half its depth along
    the normal, back onto A's part) inside other parts of A, or all of B's (half its depth
    the other way) inside other parts of B. All manifold slots of all contacts at once."""
    count = found.manifold_count[rows]
    used = np.arange(found.manifold_points.shape[1])[None, :] < count[:, None]  # (k, 8)
    k, slot = np.nonzero(used)  # every valid manifold point, contact-major
    half = 0.5 * found.manifold_depths[rows[k], slot][:, None] * found.normal[rows[k]]
    points, at = found.manifold_points[rows[k], slot], pose[rows[k]]
    out_a = ~_inside_other_part(points + half, at, i[rows[k]], *body_a)
    out_b = ~_inside_other_part(points - half, at, j[rows[k]], *body_b)
    covered_a = np.bincount(k, out_a, minlength=len(rows)) == 0  # no point outside
    covered_b = np.bincount(k, out_b, minlength=len(rows)) == 0
    return (count > 0) & (covered_a | covered_b)


def _inside_other_part(point, pose, own, position, _quaternion, rot, table) -> np.ndarray:
    """(k,) bool: ``point`` (k, 3, world) lies inside a part of the body (origins ``position``
    (n, 3), rotations ``rot`` (n, 3, 3), parts in ``table``) other than ``own`` (k,), by more
    than :data:`INSIDE_MARGIN_REL` of that part's smallest extent across every face. Only the
    parts whose bounds overlap the own part's can hold its points (``table.partners``): box
    parts are tested by their bounds, convex parts by their faces."""
    local = np.einsum("kji,kj->ki", rot[pose], point - position[pose])  # R^T (x - p)
    start, partner = table.partners
    count = start[own + 1] - start[own]
    item = np.repeat(np.arange(len(own)), count)
    other = partner[np.repeat(start[own] - np.cumsum(count) + count, count)
                    + np.arange(len(item))]
    margin = INSIDE_MARGIN_REL * table.size.min(axis=1)
    gap = np.abs(local[item] - table.centre[other])  # (items, 3)
    half = 0.5 * table.size[other]
    inside = (gap < half - margin[other][:, None]).all(axis=1) & table.is_box[other]
    near = (gap < half).all(axis=1) & ~table.is_box[other]
    for part in np.unique(other[near]):
        at = np.flatnonzero(near & (other == part))
        normals, offsets = table.hulls[part].inside_planes()
        depth = (local[item[at]] @ normals.T - offsets).max(axis=1)
        inside[at] = depth < -margin[part]
    return np.bincount(item, inside, minlength=len(own)) > 0
