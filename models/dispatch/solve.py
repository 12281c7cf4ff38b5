"""The dispatcher: the one entry from N pairs of bodies and a mode to their answers, for box and
compound pairs alike (issue #33).

Every pair has a chain: a learned link where the bundle serves one for that pair in that mode,
then the exact link. Box pairs go through the box chain in one batched call whatever their
sizes (the learned box predictors look each pair up once, and send the pairs they have no model
for, or are unsure of, to the exact solver); compound pairs through their pair's learned chain
(modes ``auto`` and ``committee``, where the bundle serves the pair learned) or the exact
compound oracle. A pair recorded exact-only is settled at the first lookup: it never enters a
learned link. The answer has one shape (:mod:`impactnet.models.dispatch.answers`).

    dispatcher = Dispatcher()                       # exact only, or with a bundle's chains
    answers = dispatcher.answer(pairs, mode="exact")

A server splits the same work in three steps, to admit it before it runs:
:meth:`Dispatcher.plan` (cheap: the split), :meth:`Dispatcher.count` (the broadphase's count
under the caps), then :meth:`Dispatcher.solve` (slices, a deadline checkpoint between them,
the part-contact caps checked slice by slice).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.box.exact import box_box
from impactnet.models.compiled import CHUNK_ROWS, chunks
from impactnet.models.compound.body_table import body_table
from impactnet.models.compound.candidates import answer_of_poses, pose_slices
from impactnet.models.dispatch import plan as plans
from impactnet.models.dispatch.answers import Answers, Pieces
from impactnet.models.dispatch.shapes import Pairs
from impactnet.models.distance.bodies import bodies_gaps, box_bodies
from impactnet.models.learned.pair_dispatch import UnsupportedPairError
from impactnet.models.work import checkpoint

#: Predictor name of the compound oracle's rows.
ORACLE = "oracle"
#: No per-pose contact counts (box rows: one contact at most each).
_NO_COUNTS = np.zeros(0, np.int64)


class Dispatcher:
    """Chains per pair (module docstring).

    Parameters
    ----------
    box_predictors : dict, optional
        Mode -> a box predictor (``box_box``'s signature, returning `Contacts` with
        ``predictor`` and ``confidence``) for the learned modes; mode ``exact`` is always
        :func:`~impactnet.models.box.exact.box_box`.
    compound_chains : dict, optional
        ``"a/b"`` (scene object names) -> the learned chain of a compound pair the bundle
        serves learned.
    """

    def __init__(self, box_predictors: dict | None = None,
                 compound_chains: dict | None = None) -> None:
        self.box_predictors = {"exact": box_box, **(box_predictors or {})}
        self.compound_chains = compound_chains or {}

    def _chains(self, mode: str):
        if mode not in ("auto", "committee") or not self.compound_chains:
            return lambda a, b: None
        return lambda a, b: (self.compound_chains.get(f"{a.name}/{b.name}")
                             if a.name and b.name else None)

    def plan(self, pairs: Pairs, mode: str = "exact", include=(), margin: float = 0.0,
             caps: plans.Caps = plans.Caps(), separated: bool = True) -> plans.Plan:
        """The split of the rows (cheap: :func:`impactnet.models.dispatch.plan.plan`);
        ``separated=False``: rows without contact beyond the margin are not asked for their
        separating direction (a caller that drops them, such as a frame)."""
        return plans.plan(pairs, mode, self._chains(mode), include, margin, caps, separated)

    def count(self, plan: plans.Plan, caps: plans.Caps = plans.Caps()) -> plans.Plan:
        """The broadphase's count under ``caps``
        (:func:`impactnet.models.dispatch.plan.count`)."""
        return plans.count(plan, caps)

    def solve(self, plan: plans.Plan, caps: plans.Caps = plans.Caps()) -> Answers:
        """The answers of a counted plan (module docstring)."""
        pieces = Pieces(len(plan.pairs), "manifold" in plan.include)
        if len(plan.box_rows):
            _box_rows(pieces, plan, self.box_predictors[plan.mode], caps)
            if plan.margin > 0.0:
                _box_gaps(pieces, plan)
        for group in plan.groups:
            for start, stop in pose_slices(group.candidates.counts, plans.SLICE_CANDIDATES):
                checkpoint()
                _compound_slice(pieces, group, start, stop, plan.mode, caps)
        if plan.apart is not None:  # one set of columns, whatever their shapes
            checkpoint()
            pieces.add(plan.apart.rows, {}, ORACLE, np.zeros(0, np.int64),
                       _no_contacts(pieces.manifold))
        _separated_gaps(pieces, plan)
        return pieces.merged()

    def answer(self, pairs: Pairs, mode: str = "exact", include=(), margin: float = 0.0,
               caps: plans.Caps = plans.Caps(), separated: bool = True) -> Answers:
        """Plan, count and solve in one call (a library caller); ``separated``: as
        :meth:`plan`'s."""
        return self.solve(self.count(self.plan(pairs, mode, include, margin, caps, separated),
                                     caps), caps)


def _check_contacts(counts: np.ndarray, rows: np.ndarray, total: int,
                    caps: plans.Caps) -> None:
    if caps.contacts_per_pose is not None and counts.size and counts.max() > \
            caps.contacts_per_pose:
        worst = int(np.argmax(counts))
        raise plans.TooManyContacts(int(rows[worst]), int(counts[worst]),
                                    caps.contacts_per_pose)
    if caps.contacts_per_request is not None and total > caps.contacts_per_request:
        raise plans.TooManyContacts(None, total, caps.contacts_per_request)


def _contact_columns(c, rows, code_a, code_b, manifold: bool) -> dict:
    """Part-contact columns of `Contacts` rows ``rows`` (their parts' codes given)."""
    out = {"part_a": code_a, "part_b": code_b, "point": c.point[rows],
           "normal": c.normal[rows], "depth": c.depth[rows],
           "contact_type": c.contact_type_code[rows].astype(np.int8, copy=False),
           "feature_a": c.feature_a[rows].astype(np.int32, copy=False),
           "feature_b": c.feature_b[rows].astype(np.int32, copy=False),
           "axis": c.axis[rows].astype(np.int8, copy=False), "pressure": c.pressure[rows]}
    if manifold:
        out |= {"manifold_count": c.manifold_count[rows],
                "manifold_points": c.manifold_points[rows],
                "manifold_depths": np.maximum(c.manifold_depths[rows], 0.0) + 0.0}
    return out


def _box_codes(pieces: Pieces, pairs) -> np.ndarray:
    """The part code of each box shape of ``pairs`` (a box is a body of one part, every box's
    the same code); -1 for the others."""
    is_box = pairs.table.is_box
    if not is_box.any():
        return np.full(len(is_box), -1, np.int32)
    code = pieces.codes_of(pairs.shapes[int(np.argmax(is_box))])[0]
    return np.where(is_box, code, -1).astype(np.int32)


def _box_rows(pieces: Pieces, plan: plans.Plan, predictor, caps: plans.Caps) -> None:
    """The box rows through the box chain, in chunks (one contact per touching pair); a
    chunk of one row goes in as vectors (the predictors' one-pair entry: fewest NumPy calls)."""
    pairs, rows = plan.pairs, plan.box_rows
    if not len(rows):
        return
    sizes = pairs.table.size
    index_a, index_b = pairs.column("shape_a"), pairs.column("shape_b")
    code = pieces.codes_of(pairs.shapes[int(index_a[rows[0]])])[0]  # every box's part code
    unsupported: list[np.ndarray] = []
    every = len(rows) == len(pairs)  # every row is a box pair: chunks are slices
    for start, stop in chunks(len(rows), CHUNK_ROWS):
        at = rows[start:stop]
        take = slice(start, stop) if every else at
        p_a, q_a, p_b, q_b = pairs.poses(take)
        inputs = (sizes[index_a[take]], p_a, q_a, sizes[index_b[take]], p_b, q_b)
        try:
            c = predictor(*(v[0] for v in inputs) if len(at) == 1 else inputs)
        except UnsupportedPairError as exc:  # go on: the error names every such row
            unsupported.append(at[np.asarray(exc.rows, np.int64)])
            missing = exc
            continue
        hit = np.flatnonzero(c.colliding)
        _check_contacts(_NO_COUNTS, at, pieces.contacts + len(hit), caps)
        parts = np.where(c.colliding, np.int32(code), np.int32(-1))
        hit_parts = parts[hit]
        body = {"colliding": c.colliding, "point": c.point, "normal": c.normal,
                "depth": c.depth, "contact_type": c.contact_type_code,
                "feature_a": c.feature_a, "feature_b": c.feature_b, "part_a": parts,
                "part_b": parts.copy(), "cluster_size": c.colliding.astype(np.int64),
                "confidence": c.confidence,
                "distance": np.where(c.colliding, -c.depth, np.inf)}
        pieces.add(at, body, c.predictor, at[hit],
                   _contact_columns(c, hit, hit_parts, hit_parts.copy(), pieces.manifold))
    if unsupported:  # a strict learned mode without a model for these box sizes
        raise UnsupportedPairError(np.concatenate(unsupported), missing.pairs, plan.mode)


def _deepest(parts, n: int) -> np.ndarray:
    """(n,) the row of each pose's deepest part contact (-1 where none)."""
    deepest = np.full(n, -1, np.int64)
    counts = np.diff(parts.offsets)
    hit = counts > 0
    if hit.any():
        order = np.lexsort((-parts.contacts.depth, parts.pose))
        deepest[hit] = order[parts.offsets[:-1][hit]]
    return deepest


def _compound_slice(pieces: Pieces, group: plans.Group, start: int, stop: int, mode: str,
                    caps: plans.Caps) -> None:
    """Poses ``start:stop`` of a group through its chain or the oracle."""
    if group.chain is None:
        answer = answer_of_poses(group.shape_a.parts, *group.poses[:2], group.shape_b.parts,
                                 *group.poses[2:], group.candidates, start, stop)
        parts, summary, predictor = answer.parts, answer.summary, ORACLE
    else:
        p_a, q_a, p_b, q_b = (c[start:stop] for c in group.poses)
        got = group.chain.answer(p_a, q_a, p_b, q_b, fallback=mode == "auto")
        parts, summary, predictor = got.parts, got.summary, got.predictor
    rows = group.rows[start:stop]
    _check_contacts(np.diff(parts.offsets), rows, pieces.contacts + len(parts.pose), caps)
    codes_a, codes_b = pieces.codes_of(group.shape_a), pieces.codes_of(group.shape_b)
    c = parts.contacts
    deepest = _deepest(parts, stop - start)
    hit = deepest >= 0
    pick = np.where(hit, deepest, 0)

    def of_deepest(values, empty):
        return np.where(hit, values[pick], empty) if len(values) else np.full(len(hit), empty)

    body = {"colliding": summary.colliding, "point": summary.point, "normal": summary.normal,
            "depth": summary.depth, "cluster_size": summary.cluster_size,
            "contact_type": of_deepest(c.contact_type_code, 0),
            "feature_a": of_deepest(c.feature_a, -1), "feature_b": of_deepest(c.feature_b, -1),
            "part_a": of_deepest(codes_a[parts.part_a], -1),
            "part_b": of_deepest(codes_b[parts.part_b], -1),
            "confidence": of_deepest(c.confidence, 1.0),
            "distance": np.where(summary.colliding, -summary.depth, np.inf)}
    every = np.arange(len(parts.pose))
    pieces.add(rows, body, predictor, rows[parts.pose],
               _contact_columns(c, every, codes_a[parts.part_a], codes_b[parts.part_b],
                                pieces.manifold))


def _no_contacts(manifold: bool) -> dict:
    """The part-contact columns of a slice without contacts (the manifold's where asked)."""
    from impactnet.models.dispatch.answers import CONTACT_COLUMNS, MANIFOLD_COLUMNS

    wanted = CONTACT_COLUMNS + (MANIFOLD_COLUMNS if manifold else ())
    return {name: np.zeros((0, *shape), dtype) for name, dtype, shape in wanted}


def _shape_bodies(pairs, used: np.ndarray) -> tuple[list, np.ndarray]:
    """(the gap query's bodies, each shape's body number (s,), -1 unused) of the shapes
    ``used`` (u,) of ``pairs``: every box among them one row of :func:`box_bodies`, the others
    their body tables."""
    table = pairs.table
    boxes, others = used[table.is_box[used]], used[~table.is_box[used]]
    bodies = ([box_bodies(table.size[boxes])] if len(boxes) else []) + \
        [body_table(pairs.shapes[k].parts) for k in others.tolist()]
    number = np.full(len(pairs.shapes), -1, np.int64)
    number[boxes] = np.arange(len(boxes))
    number[others] = len(boxes) + np.arange(len(others))
    return bodies, number


def _first_codes(pieces: Pieces, pairs, index: np.ndarray) -> np.ndarray:
    """(k,) the part code of the first part of shapes ``index`` (k,) of ``pairs``."""
    unique, inverse = np.unique(index, return_inverse=True)
    box = _box_codes(pieces, pairs)
    first = np.array([box[k] if box[k] >= 0 else pieces.codes_of(pairs.shapes[k])[0]
                      for k in unique.tolist()], np.int64)
    return first[inverse.reshape(-1)]


def _separated_rows(pieces: Pieces, plan: plans.Plan) -> np.ndarray:
    """The compound rows without contact, once their groups are solved: the near groups' rows
    that do not touch, then the rows that cannot touch. Where the caller drops the rows apart
    beyond a margin of 0 (:attr:`Plan.gaps` False), only the rows whose part bounds met: a
    row whose parts overlap while its contacts were all filtered (on covered surfaces) has a
    gap of 0 and is kept, as the pairwise API keeps it; the others' gaps are positive."""
    colliding = pieces.body["colliding"]
    if not plan.gaps:
        rows = [g.rows[~colliding[g.rows] & (g.candidates.counts > 0)] for g in plan.groups]
    else:
        rows = [g.rows[~colliding[g.rows]] for g in plan.groups]
        rows += [plan.apart.rows] if plan.apart is not None else []
    return np.concatenate(rows) if rows else np.zeros(0, np.int64)


def _separated_gaps(pieces: Pieces, plan: plans.Plan) -> None:
    """Every compound row without contact (:func:`_separated_rows`): the separating direction
    and the midpoint of its closest part pair (:mod:`impactnet.models.distance.bodies`), the gap
    as its distance where it is within the margin; one call of the gap query whatever the
    number of groups and distinct shapes."""
    rows = _separated_rows(pieces, plan)
    if not len(rows):
        return
    pairs, separated = plan.pairs, plans.Apart.of(plan.pairs, rows)
    used = np.unique(np.concatenate([separated.shape_a, separated.shape_b]))
    bodies, number = _shape_bodies(pairs, used)
    gaps = bodies_gaps(bodies, number[separated.shape_a], number[separated.shape_b],
                       *separated.poses)
    within = gaps.distance <= plan.margin
    first_a, first_b = (np.zeros(len(rows), np.int64) for _ in "ab")
    if within.any():
        first_a[within] = _first_codes(pieces, pairs, separated.shape_a[within])
        first_b[within] = _first_codes(pieces, pairs, separated.shape_b[within])
    _write_gaps(pieces, rows, gaps, plan.margin, first_a, first_b)


def _write_gaps(pieces: Pieces, rows: np.ndarray, gaps, margin: float, first_a: np.ndarray,
                first_b: np.ndarray) -> None:
    """The gap answers of ``rows`` (k,) into ``pieces``; ``first_a``, ``first_b`` (k,): the
    part code of each row's first part of A and of B."""
    within = gaps.distance <= margin
    pieces.body["normal"][rows] = gaps.direction
    pieces.body["point"][rows] = gaps.point
    pieces.body["distance"][rows] = np.where(within, gaps.distance, np.inf)
    near = rows[within]
    pieces.body["closest_a"][near] = gaps.point_a[within]
    pieces.body["closest_b"][near] = gaps.point_b[within]
    pieces.body["part_a"][near] = first_a[within] + gaps.part_a[within]
    pieces.body["part_b"][near] = first_b[within] + gaps.part_b[within]


def _box_gaps(pieces: Pieces, plan: plans.Plan) -> None:
    """Box rows apart by less than the margin: their gap and the closest region's centroid
    (the box solver's separating axis stays their normal); one call whatever their sizes."""
    rows = plan.box_rows[~pieces.body["colliding"][plan.box_rows]]
    if not len(rows):
        return
    rows = rows[plans.reachable(plan.pairs, rows, plan.margin)]
    if not len(rows):
        return
    index = [plan.pairs.column(f"shape_{side}")[rows].astype(np.int64) for side in "ab"]
    bodies, number = _shape_bodies(plan.pairs, np.unique(np.concatenate(index)))
    gaps = bodies_gaps(bodies, number[index[0]], number[index[1]], *plan.pairs.poses(rows))
    within = gaps.distance <= plan.margin
    near = rows[within]
    pieces.body["distance"][near] = gaps.distance[within]
    pieces.body["point"][near] = gaps.point[within]
    pieces.body["closest_a"][near] = gaps.point_a[within]
    pieces.body["closest_b"][near] = gaps.point_b[within]
    code = _box_codes(pieces, plan.pairs)
    for side in "ab":
        pieces.body[f"part_{side}"][near] = code[plan.pairs.column(f"shape_{side}")[near]]
