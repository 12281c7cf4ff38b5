"""What a request will cost, known before any contact is solved (the dispatcher's first step).

Rows of N pairs split three ways:

* **box rows** (two boxes): one batched call of the box chain, whatever their sizes; their work
  is one box-pair solve each;
* **rows that cannot touch**: their bodies' bounding spheres do not meet; answered "no
  contact" with no per-pair setup (one :class:`Apart` of columns, whatever their shapes), their
  gap and separating direction in one call of the gap query;
* **compound rows** (a body made of parts): grouped by their pair of shapes; the broadphase
  counts each group's candidate part pairs under the caps (:class:`Caps`), and their work is
  the candidates weighted by their hulls' sizes
  (:func:`~impactnet.models.compound.candidates.pair_work`).

:attr:`Plan.work` (box-pair solves) chooses where the work runs; :meth:`Plan.memory_bytes`
is what it may allocate, reserved before it starts.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from impactnet.models.compound.candidates import Candidates, candidate_pairs
from impactnet.models.dispatch.shapes import Pairs
from impactnet.models.geometry.rotations import quaternion_to_matrix

#: Slack (x the two radii) of the reach test: far above round-off, far below any gap.
REACH_SLACK_REL = 1e-9
#: Part pairs the broadphase tests in the time of one box-pair solve (~1 us).
PART_PAIRS_PER_UNIT = 16
#: Bytes per candidate part pair held from the count to the end (pose, part_a, part_b).
CANDIDATE_BYTES = 24
#: Upper bound of one slice's working set, bytes (a slice of :data:`SLICE_CANDIDATES`).
SLICE_WORKING_BYTES = 48 << 20
#: Candidates per slice of the narrowphase: a few tens of ms between two checkpoints.
SLICE_CANDIDATES = 2048
#: Bytes per part contact of the answer: the compact columns twice (slices, then their merge).
CONTACT_BYTES = 2 * 96
#: Bytes of the manifold of a part contact (asked with include=manifold), twice.
MANIFOLD_BYTES = 2 * 256
#: Bytes per row of the body-level columns and of a box row's solve.
ROW_BYTES = 512


@dataclass(frozen=True)
class Caps:
    """The caps of a request (the service's settings of the same meaning)."""

    candidates_per_pose: int | None = None  # candidate part pairs of one pose
    candidates_per_request: int | None = None  # candidate part pairs of all poses
    contacts_per_pose: int | None = None  # part contacts of one pose
    contacts_per_request: int | None = None  # part contacts of all poses
    shape_pairs_per_request: int | None = None  # distinct pairs of shapes of compound rows
    # that may touch: each costs a setup (its bodies' tables, ~2-5 ms for a body of one part)


class TooManyShapePairs(ValueError):
    """The compound rows that may touch name more than ``cap`` distinct pairs of shapes
    (``count``): refused by the plan, before any group is formed."""

    def __init__(self, count: int, cap: int) -> None:
        self.count, self.cap = count, cap
        super().__init__(f"{count} distinct pairs of shapes may touch: more than {cap}")


class TooManyContacts(ValueError):
    """A pose or the request passed a part-contact cap: ``row`` (None for the request),
    ``count`` and ``cap``."""

    def __init__(self, row: int | None, count: int, cap: int) -> None:
        self.row, self.count, self.cap = row, count, cap
        where = f"row {row}" if row is not None else "the request"
        super().__init__(f"{where}: more than {cap} part contacts ({count})")


@dataclass
class Group:
    """The compound rows of one pair of shapes."""

    rows: np.ndarray  # (k,) int64 request rows
    shape_a: object  # Shape
    shape_b: object
    poses: tuple  # position_a (k, 3), quaternion_a (k, 4), position_b, quaternion_b
    chain: object | None = None  # the pair's learned chain in this mode; None: the oracle
    candidates: Candidates | None = None  # set when counted


@dataclass
class Apart:
    """The compound rows whose bodies cannot touch, as columns (whatever their shapes: a batch
    of many distinct box sizes forms no group per size)."""

    rows: np.ndarray  # (k,) int64 request rows
    shape_a: np.ndarray  # (k,) int64 index into the pairs' shapes
    shape_b: np.ndarray
    poses: tuple  # position_a (k, 3), quaternion_a (k, 4), position_b, quaternion_b

    @classmethod
    def of(cls, pairs: Pairs, rows: np.ndarray) -> Apart:
        return cls(rows, pairs.column("shape_a")[rows].astype(np.int64),
                   pairs.column("shape_b")[rows].astype(np.int64), pairs.poses(rows))

    def part_pairs(self, pairs: Pairs) -> int:
        """The part pairs of every row (the gap query's bound: its work)."""
        parts = pairs.table.parts
        return int((parts[self.shape_a] * parts[self.shape_b]).sum())


@dataclass
class Plan:
    """A request admitted by its count (module docstring)."""

    pairs: Pairs
    mode: str
    box_rows: np.ndarray  # (b,) rows of two boxes
    groups: list[Group] = field(default_factory=list)  # compound rows that may touch
    apart: Apart | None = None  # compound rows that cannot touch
    include: tuple = ()  # "manifold"
    margin: float = 0.0  # metres: pairs apart by less get their distance and closest points
    separated: bool = True  # rows without contact get their separating direction (a frame
    # at margin 0 drops them: False asks the gap query only of rows whose part bounds met)
    candidates: int = 0  # candidate part pairs of all groups
    work: float = 0.0  # box-pair solves

    @property
    def gaps(self) -> bool:
        """Whether every compound row without contact is given its gap query's answer (else
        only those whose part bounds met: the dispatcher's ``_separated_rows``)."""
        return self.separated or self.margin > 0.0

    def memory_bytes(self, contacts_cap: int | None) -> int:
        """What the solve may allocate: the rows, the candidates, one slice, the answer."""
        contacts = self.candidates + len(self.box_rows)
        if contacts_cap is not None:
            contacts = min(contacts, contacts_cap)
        per_contact = CONTACT_BYTES + (MANIFOLD_BYTES if "manifold" in self.include else 0)
        return (len(self.pairs) * ROW_BYTES + self.candidates * CANDIDATE_BYTES
                + SLICE_WORKING_BYTES * bool(self.candidates) + contacts * per_contact)


def _spheres(pairs: Pairs, side: str, rows: np.ndarray):
    """World centres (k, 3) and radii (k,) of one side's bodies on ``rows``."""
    index = pairs.column(f"shape_{side}")[rows]
    centre, radius = pairs.table.spheres
    q = pairs.column(f"quaternion_{side}")[rows]
    moved = np.einsum("nij,nj->ni", quaternion_to_matrix(q), centre[index])
    return pairs.column(f"position_{side}")[rows] + moved, radius[index]


def reachable(pairs: Pairs, rows: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(k,) bool: ``rows`` whose bodies' bounding spheres meet, grown by ``margin``."""
    (centre_a, radius_a), (centre_b, radius_b) = (_spheres(pairs, s, rows) for s in "ab")
    reach = (radius_a + radius_b) * (1.0 + REACH_SLACK_REL) + margin
    return np.linalg.norm(centre_b - centre_a, axis=1) <= reach


def _split(pairs: Pairs, rows: np.ndarray, chains, cap: int | None = None) -> list[Group]:
    """The compound ``rows`` grouped by their pair of shapes (raises
    :class:`TooManyShapePairs` past ``cap`` distinct pairs, before any group is formed)."""
    if len(rows) == 1 and (cap is None or cap >= 1):  # one row: one group (no sort)
        a, b = (pairs.shapes[int(pairs.column(f"shape_{s}")[rows[0]])] for s in "ab")
        return [Group(rows, a, b, pairs.poses(rows), chains(a, b))]
    key = (pairs.column("shape_a")[rows].astype(np.int64) * len(pairs.shapes)
           + pairs.column("shape_b")[rows])
    unique, inverse = np.unique(key, return_inverse=True)
    if cap is not None and len(unique) > cap:
        raise TooManyShapePairs(len(unique), cap)
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(len(unique) + 1))
    groups = []
    for g, k in enumerate(unique.tolist()):
        take = rows[order[bounds[g]:bounds[g + 1]]]
        a, b = pairs.shapes[k // len(pairs.shapes)], pairs.shapes[k % len(pairs.shapes)]
        groups.append(Group(take, a, b, pairs.poses(take), chains(a, b)))
    return groups


def plan(pairs: Pairs, mode: str, chains=lambda a, b: None, include=(),
         margin: float = 0.0, caps: Caps = Caps(), separated: bool = True) -> Plan:
    """The rows split (module docstring), compound rows grouped but not yet counted
    (:func:`count`); ``chains(shape_a, shape_b)`` names a compound pair's learned chain;
    ``caps.shape_pairs_per_request`` bounds the groups (:class:`TooManyShapePairs`);
    ``separated``: :attr:`Plan.separated`."""
    boxes = pairs.table.is_box
    both = boxes[pairs.column("shape_a")] & boxes[pairs.column("shape_b")]
    box_rows = np.flatnonzero(both)
    rows = np.flatnonzero(~both)
    near = reachable(pairs, rows) if len(rows) else np.zeros(0, bool)
    groups = (_split(pairs, rows[near], chains, caps.shape_pairs_per_request)
              if near.any() else [])
    apart = Apart.of(pairs, rows[~near]) if (~near).any() else None
    out = Plan(pairs, mode, box_rows, groups, apart, tuple(include), float(margin), separated)
    part_pairs = sum(len(g.rows) * len(g.shape_a.parts) * len(g.shape_b.parts)
                     for g in groups) + (apart.part_pairs(pairs) if apart and out.gaps else 0)
    out.work = len(box_rows) + part_pairs / PART_PAIRS_PER_UNIT
    return out


def count(plan_: Plan, caps: Caps) -> Plan:
    """The broadphase's count of every group under ``caps`` (raises
    :class:`~impactnet.models.compound.candidates.TooManyCandidates` with the request row)."""
    from impactnet.models.compound.candidates import TooManyCandidates

    total, work = 0, float(len(plan_.box_rows))
    for group in plan_.groups:
        left = None if caps.candidates_per_request is None else (
            caps.candidates_per_request - total)
        try:
            group.candidates = candidate_pairs(
                group.shape_a.parts, group.poses[0], group.poses[1], group.shape_b.parts,
                group.poses[2], group.poses[3], caps.candidates_per_pose, left)
        except TooManyCandidates as exc:
            pose = None if exc.pose is None else int(group.rows[exc.pose])
            raise TooManyCandidates(pose, exc.count if pose is not None else total + exc.count,
                                    exc.cap if pose is not None else
                                    caps.candidates_per_request) from None
        total += group.candidates.total
        work += group.candidates.work + len(group.rows)
    if plan_.apart is not None and plan_.gaps:  # their closest part pairs (branch and bound)
        work += plan_.apart.part_pairs(plan_.pairs) / PART_PAIRS_PER_UNIT
    plan_.candidates, plan_.work = total, work
    return plan_
