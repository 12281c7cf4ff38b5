"""Compound bodies through the HTTP API: the work admitted first, then solved in bounded slices.

For the rows of a request that name a compound body (a scene object made of parts, or inline
``parts``):

1. **Reach** (:func:`groups_of_pairs`): rows whose bodies' bounding spheres do not meet are
   answered "no contact" at once, without any per-pair setup; the others are grouped by their
   pair of bodies (object names, or raw box sizes).
2. **Admission** (:func:`admit`): the broadphase counts every group's candidate part pairs, and
   a pose or a request past its cap (``max_candidates_per_pose``,
   ``max_candidates_per_request``) is 413 ``too_many_candidates`` before any contact is solved;
   then the request reserves, in its memory lease, the candidates, one slice's working set and
   the largest answer they can give (503 ``overloaded`` when there is no room now, 413 when
   there never is).
3. **Solve** (:func:`solve`): each group's poses in slices of at most :data:`SLICE_CANDIDATES`
   candidates, with a checkpoint of the request's deadline and disconnect between slices; the
   part-contact caps (``max_part_contacts_per_pose``, ``max_part_contacts_per_batch``) are
   checked slice by slice (413 ``too_many_part_contacts`` as soon as one is passed).

Modes (issue #21): a pair that the bundle serves learned (``chains``) is answered in mode
``auto`` by its chain (classifier, experts, the oracle for unsure rows) and in mode
``committee`` by its chain without the oracle; every other mode and pair by the oracle.
``predictor`` names, per row, ``oracle``, ``exact-part`` or ``learned``.

The answer (:class:`CompoundArrays`) is compact: part names and contact types as codes into
small tables, turned into names only while encoding (:mod:`impactnet.service.codecs.
compound_encode`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.compound.body_table import TransientParts, body_table
from impactnet.models.compound.candidates import (
    Candidates,
    TooManyCandidates,
    answer_of_poses,
    candidate_pairs,
    pose_slices,
)
from impactnet.models.compound.parts import BoxPart
from impactnet.models.geometry.rotations import quaternion_to_matrix
from impactnet.models.work import checkpoint
from impactnet.service.compound_arrays import CompoundArrays, Pieces
from impactnet.service.errors import LimitRefused
from impactnet.service.limits.budget import Lease
from impactnet.service.predictors import PairInputs
from impactnet.service.scene import SceneView

#: The predictor named in compound answers of the oracle.
ORACLE = "oracle"
#: Candidates per slice of the narrowphase: ~20-60 ms of work between two checkpoints at
#: ~10-30 us a candidate, and a working set of ~40 MB (:data:`SLICE_WORKING_BYTES`).
SLICE_CANDIDATES = 2048
#: Upper bound of one slice's working set, bytes (tracemalloc peaks of 2,048-candidate slices:
#: spreader landings, stacked containers at detail 2, the cell guide; docs/service.md).
SLICE_WORKING_BYTES = 48 << 20
#: Bytes per candidate part pair held from admission to the end (pose, part_a, part_b int64).
CANDIDATE_BYTES = 24
#: Bytes per part contact of the answer: the compact arrays (~84) twice (the slices' pieces
#: and their merge), and one member turned into names while encoding (~92).
CONTACT_BYTES = 2 * 84 + 96
#: Bytes per row of the answer's summary columns.
SUMMARY_ROW_BYTES = 96
#: Part pairs the broadphase tests in the time of one box-pair solve (~1 us): 1,000 poses of
#: two 71-part containers (5 M part pairs) take ~0.3 s.
PART_PAIRS_PER_UNIT = 16
#: Slack (x the two radii) of the reach test: far above round-off, far below any gap.
REACH_SLACK_REL = 1e-9


@dataclass(frozen=True)
class CompoundCaps:
    """The caps of a compound request (settings of the same names)."""

    candidates_per_pose: int  # max_candidates_per_pose
    candidates_per_request: int  # max_candidates_per_request
    contacts_per_pose: int  # max_part_contacts_per_pose
    contacts_per_request: int  # max_part_contacts_per_batch

    @classmethod
    def of(cls, settings) -> CompoundCaps:
        return cls(settings.max_candidates_per_pose, settings.max_candidates_per_request,
                   settings.max_part_contacts_per_pose, settings.max_part_contacts_per_batch)


@dataclass
class Group:
    """The rows of a request with one pair of bodies, and their candidates once admitted."""

    rows: np.ndarray  # (k,) int64, the request's rows
    parts_a: tuple  # A's parts (body frame)
    parts_b: tuple  # B's parts
    poses: tuple  # position_a (k, 3), quaternion_a (k, 4), position_b, quaternion_b
    chain: object | None = None  # the pair's learned chain in this mode, else None: oracle
    candidates: Candidates | None = None  # set by admit()


@dataclass(frozen=True)
class Plan:
    """An admitted compound request: its groups with their candidates."""

    n: int  # rows of the request
    groups: list[Group]
    work: float  # admitted work in box-pair solves (candidates weighted by hull sizes)


def names_compound(pairs: PairInputs, scene: SceneView) -> bool:
    """Whether a row of ``pairs`` (parsed against ``scene.with_compound``) names a compound
    object."""
    box_count = len(scene.object_names)
    return bool((pairs.object_a >= box_count).any() or (pairs.object_b >= box_count).any())


def _column(values, n: int) -> np.ndarray:
    return np.broadcast_to(values, (n,) + values.shape[1:])


def _sphere(parts) -> tuple[np.ndarray, float]:
    """(centre (3,) in the body frame, radius) of a sphere around every part."""
    table = body_table(parts)
    lo = (table.centre - 0.5 * table.size).min(axis=0)
    hi = (table.centre + 0.5 * table.size).max(axis=0)
    return 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))


def _spheres(objects, sizes, position, quaternion, scene: SceneView):
    """World centres (n, 3) and radii (n,) of the bodies of one side of n rows."""
    n = len(objects)
    radius = 0.5 * np.linalg.norm(sizes, axis=1)
    local = np.zeros((n, 3))
    box_count = len(scene.object_names)
    for index in np.unique(objects[objects >= box_count]):
        rows = objects == index
        local[rows], radius[rows] = _sphere(scene.parts_of(int(index), None))
    moved = np.einsum("nij,nj->ni", quaternion_to_matrix(quaternion), local)
    return position + moved, radius


def reachable(pairs: PairInputs, scene: SceneView) -> np.ndarray:
    """(n,) bool: the rows whose bodies' bounding spheres meet (the others cannot touch)."""
    n = len(pairs)
    sides = [_spheres(_column(o, n), _column(s, n), _column(p, n), _column(q, n), scene)
             for o, s, p, q in ((pairs.object_a, pairs.size_a, pairs.position_a,
                                 pairs.quaternion_a),
                                (pairs.object_b, pairs.size_b, pairs.position_b,
                                 pairs.quaternion_b))]
    (centre_a, radius_a), (centre_b, radius_b) = sides
    reach = (radius_a + radius_b) * (1.0 + REACH_SLACK_REL)
    return np.linalg.norm(centre_b - centre_a, axis=1) <= reach


def _split(rows: np.ndarray, keys: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """``rows`` grouped by equal ``keys`` rows ((k, w) floats): (rows of a group, its key)."""
    if len(rows) == 1 or not (keys != keys[0]).any():
        return [(rows, keys[0])]
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(unique) + 1))
    return [(rows[order[bounds[g]:bounds[g + 1]]], unique[g]) for g in range(len(unique))]


def _keyed_rows(pairs: PairInputs, rows: np.ndarray, n: int):
    """(rows, key) of each distinct pair of bodies among ``rows``; key = (object_a, object_b,
    size_a (3,), size_b (3,)). Scene objects are grouped by their indices (one integer
    comparison), raw sizes by their values."""
    objects = np.stack([_column(pairs.object_a, n)[rows], _column(pairs.object_b, n)[rows]],
                       axis=1).astype(np.float64)
    out = []
    for part, key in _split(rows, objects):
        if key.min() >= 0:  # both named: the sizes follow from the names
            size_a, size_b = (_column(c, n)[part[0]] for c in (pairs.size_a, pairs.size_b))
            out.append((part, np.concatenate([key, size_a, size_b])))
            continue
        sizes = np.concatenate([_column(pairs.size_a, n)[part], _column(pairs.size_b, n)[part]],
                               axis=1)
        out += [(sub, np.concatenate([key, size])) for sub, size in _split(part, sizes)]
    return out


def groups_of_pairs(pairs: PairInputs, scene: SceneView, chains: dict | None,
                    mode: str) -> list[Group]:
    """The groups of the rows that can touch (module docstring, step 1)."""
    n = len(pairs)
    rows = np.flatnonzero(reachable(pairs, scene))
    if not len(rows):
        return []
    groups = []
    for take, key in _keyed_rows(pairs, rows, n):
        poses = tuple(_column(c, n)[take] for c in (pairs.position_a, pairs.quaternion_a,
                                                    pairs.position_b, pairs.quaternion_b))
        groups.append(Group(take, scene.parts_of(int(key[0]), key[2:5]),
                            scene.parts_of(int(key[1]), key[5:8]), poses,
                            _chain_for(key, scene, chains or {}, mode)))
    return groups


def _chain_for(key, scene: SceneView, chains: dict, mode: str):
    """The chain that answers a group (its object indices in ``key``) in ``mode``, or None."""
    if mode not in ("auto", "committee") or not chains:
        return None
    names = scene.object_names + scene.compound_names
    a, b = int(key[0]), int(key[1])
    if min(a, b) < 0:
        return None
    return chains.get(f"{names[a]}/{names[b]}")


def box_parts(size) -> tuple:
    """A raw box size as a body of one part (built for this request)."""
    return TransientParts((BoxPart("box", tuple(float(v) for v in size)),))


def count_cost(groups: list[Group]) -> float:
    """The cost of :func:`admit`'s count in box-pair solves: every pose's part pairs, of which
    the broadphase tests :data:`PART_PAIRS_PER_UNIT` in the time of one box-pair solve."""
    pairs = sum(len(g.rows) * len(g.parts_a) * len(g.parts_b) for g in groups)
    return pairs / PART_PAIRS_PER_UNIT


def _too_many(exc: TooManyCandidates, group: Group, caps: CompoundCaps, total: int):
    if exc.pose is not None:
        row = int(group.rows[exc.pose])
        return LimitRefused("too_many_candidates", "pairs", f"row {row} has {exc.count} "
                            f"candidate part pairs, more than max_candidates_per_pose "
                            f"({exc.cap})", "max_candidates_per_pose")
    return LimitRefused("too_many_candidates", "pairs", f"the request has more than "
                        f"{caps.candidates_per_request} candidate part pairs "
                        f"(max_candidates_per_request); send fewer rows per request",
                        "max_candidates_per_request")


def admit(groups: list[Group], n: int, caps: CompoundCaps, lease: Lease | None) -> Plan:
    """Count every group's candidates under the caps, then reserve the request's memory
    (module docstring, step 2)."""
    total, work = 0, 0.0
    for group in groups:
        try:
            group.candidates = candidate_pairs(
                group.parts_a, group.poses[0], group.poses[1], group.parts_b, group.poses[2],
                group.poses[3], caps.candidates_per_pose, caps.candidates_per_request - total)
        except TooManyCandidates as exc:
            raise _too_many(exc, group, caps, total) from None
        total += group.candidates.total
        work += group.candidates.work + len(group.rows)
    if lease is not None:
        contacts = min(total, caps.contacts_per_request)
        lease.reserve(n * SUMMARY_ROW_BYTES + total * CANDIDATE_BYTES + SLICE_WORKING_BYTES
                      * bool(total) + contacts * CONTACT_BYTES,
                      f"solving {n} compound rows ({total} candidate part pairs)")
    return Plan(n, groups, work)


def _check_contacts(counts: np.ndarray, rows: np.ndarray, total: int, caps: CompoundCaps):
    if counts.size and counts.max() > caps.contacts_per_pose:
        row = int(rows[int(np.argmax(counts))])
        raise LimitRefused("too_many_part_contacts", "pairs", f"row {row} has "
                           f"{int(counts.max())} part contacts, more than "
                           f"max_part_contacts_per_pose ({caps.contacts_per_pose})",
                           "max_part_contacts_per_pose")
    if total > caps.contacts_per_request:
        raise LimitRefused("too_many_part_contacts", "pairs", f"the request has more than "
                           f"{caps.contacts_per_request} part contacts "
                           "(max_part_contacts_per_batch); send fewer rows per request",
                           "max_part_contacts_per_batch")


def _slice_answer(group: Group, start: int, stop: int, mode: str):
    """(CompoundAnswer-like (parts, summary), predictor names (stop-start,)) of one slice."""
    p_a, q_a, p_b, q_b = (c[start:stop] for c in group.poses)
    if group.chain is None:
        answer = answer_of_poses(group.parts_a, *(c for c in group.poses[:2]), group.parts_b,
                                 *(c for c in group.poses[2:]), group.candidates, start, stop)
        return answer.parts, answer.summary, np.full(stop - start, ORACLE)
    got = group.chain.answer(p_a, q_a, p_b, q_b, fallback=mode == "auto")
    return got.parts, got.summary, got.predictor


def solve(plan: Plan, caps: CompoundCaps, mode: str) -> CompoundArrays:
    """The answer of an admitted request (module docstring, step 3)."""
    pieces = Pieces(plan.n)
    for group in plan.groups:
        names = pieces.names_of(group.parts_a, group.parts_b)
        for start, stop in pose_slices(group.candidates.counts, SLICE_CANDIDATES):
            checkpoint()
            parts, summary, predictor = _slice_answer(group, start, stop, mode)
            rows = group.rows[start:stop]
            _check_contacts(np.diff(parts.offsets), rows, pieces.contacts + len(parts.pose),
                            caps)
            pieces.add(rows, parts, summary, predictor, names)
    return pieces.merged()
