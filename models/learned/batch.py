"""The learned predictors ``single`` and ``committee`` (docs/learned_predictors.md); ``auto``
is the chain of :mod:`impactnet.models.learned.chain`, the committee then the exact solver.

Each is a callable with :func:`impactnet.models.box.exact.box_box`'s signature returning
`Contacts` with ``confidence`` and ``predictor`` filled; :meth:`LearnedPredictor.predict` also
returns the committee's spread. Stages of a call:

1. Inputs are validated as the exact solver validates them
   (:mod:`impactnet.models.learned.pose_columns`); a single pair takes the plain-Python path
   (:mod:`impactnet.models.learned.one_pair`).
2. Dispatch (:mod:`impactnet.models.learned.pair_dispatch`): rows are grouped by the pair
   model their sizes match (a loop over groups, not rows); rows of a swapped pair are solved
   swapped and flipped back. Rows of a pair without this mode's models are flagged
   ``unsupported``: the strict modes raise :class:`UnsupportedPairError` for them.
3. Per group, in blocks of ``ROW_BLOCK`` rows: canonical features, then ``single``'s MLP, or
   the region classifier (:mod:`impactnet.models.learned.region_label`, the exact solver's
   decision without the clipping). ``committee`` then sorts the group's rows by region and
   runs each region's committee once on all its rows (a loop over regions), and a second
   block pass maps the canonical points to the world. Asked for the spread, it also flags the
   rows its pair's calibrated thresholds do not trust (``unsure``, for the auto chain).
4. The exact solver answers, in one call (:func:`impactnet.models.box.exact.box_box`), the
   rows whose region has no committee and the rows of a pair that the bundle serves
   exact-only (its ``decision``, issue #21), both flagged ``unknown``.

Fields of a learned answer: ``single`` predicts no contact type, so its rows have
``colliding`` True, ``contact_type_code`` 0 and features / axis -1 (not predicted), and
confidence 1 inside the trained depth domain, 0 outside it (it has no uncertainty
estimate). ``committee`` takes colliding, type, features, axis, normal and depth from the
region classifier (they equal the exact solver's) and the point from the experts;
confidence is 1, 0 where the depth leaves the trained domain; a separated row is answered
as the exact solver answers it (point: the centres' midpoint). The manifold of a learned
contact is its point (count 1). The manifold arrays are (n, 8, 3) and (n, 8) views of
slot-major (8, n, ...) arrays, so that only the slot in use is written.
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.box.decision import single_pair
from impactnet.models.box.exact import box_box
from impactnet.models.bundle.format import Bundle
from impactnet.models.learned import pose_columns as pc
from impactnet.models.learned.canonical import FALLBACK_NORMAL, FLIP_FEATURES, N_POSE_FEATURES
from impactnet.models.learned.one_pair import Prediction, predict_one
from impactnet.models.learned.pair_dispatch import (
    UNSUPPORTED,
    PairTable,
    UnsupportedPairError,
    groups,
    unswap,
)
from impactnet.models.learned.pair_runtime import AUTO_EXACT_TYPES, PairRuntime, member_stats
from impactnet.models.learned.region_label import input_block, label_block, mirrored

_FIELDS = ("colliding", "normal", "depth", "point", "contact_type_code", "feature_a",
           "feature_b", "axis", "manifold_count", "pressure", "confidence", "predictor",
           "normal_spread",
           "point_spread", "unsure", "unknown")


class Output:
    """The arrays of n answers, filled group by group (see :func:`LearnedPredictor.predict`)."""

    def __init__(self, n: int):
        self.n = n
        self.colliding, self.unsure = np.ones(n, bool), np.zeros(n, bool)
        # rows no model of this mode answers: a pair without its models, a region without a
        # committee; `unsure` (above): answered, but the pair's auto thresholds do not trust it
        self.unsupported, self.unknown = np.zeros(n, bool), np.zeros(n, bool)
        self.normal, self.point = np.empty((n, 3)), np.empty((n, 3))
        self.depth, self.confidence = np.empty(n), np.empty(n)
        self.pressure = np.zeros(n)  # the exact rows' pressure integral (m^3); 0 if learned
        self.contact_type_code, self.axis = np.zeros(n, np.int8), np.full(n, -1, np.int8)
        self.feature_a, self.feature_b = np.full(n, -1, np.int8), np.full(n, -1, np.int8)
        self.manifold_count = np.ones(n, np.int8)
        self.predictor = np.empty(n, "<U9")
        self.normal_spread, self.point_spread = np.zeros(n, np.float32), np.zeros(n, np.float32)
        self.slots = np.zeros((ct.MAX_MANIFOLD_POINTS, n, 3))  # manifold, slot-major
        self.slot_depths = np.zeros((ct.MAX_MANIFOLD_POINTS, n))

    def put(self, rows: np.ndarray, part: Output) -> None:
        """Copy the learned answers of ``part`` into ``rows``: the fields and manifold slot 0
        (a learned answer's only slot; the others stay zero until :meth:`put_exact`)."""
        for name in _FIELDS:
            getattr(self, name)[rows] = getattr(part, name)
        self.slots[0, rows] = part.slots[0]
        self.slot_depths[0, rows] = part.slot_depths[0]

    def put_exact(self, rows: np.ndarray, exact: ct.Contacts) -> None:
        """Copy exact-solver answers into ``rows``."""
        for name in _FIELDS[:-4]:
            getattr(self, name)[rows] = getattr(exact, name)
        self.normal_spread[rows] = self.point_spread[rows] = 0.0
        self.slots[:, rows] = exact.manifold_points.transpose(1, 0, 2)
        self.slot_depths[:, rows] = exact.manifold_depths.T

    def finish_learned(self, name: str) -> None:
        """Manifold slot 0 (point, depth) of the colliding rows, and the predictor name."""
        np.multiply(self.point, self.colliding[:, None], out=self.slots[0])
        self.slot_depths[0] = self.depth
        self.manifold_count[:] = self.colliding
        self.predictor[:] = name

    def prediction(self) -> Prediction:
        contacts = ct.Contacts(
            self.colliding, self.normal, self.depth, self.point, self.contact_type_code,
            self.feature_a, self.feature_b, self.axis, self.slots.transpose(1, 0, 2),
            self.slot_depths.T, self.manifold_count, self.confidence, self.predictor,
            self.pressure)
        return Prediction(contacts, self.normal_spread, self.point_spread)


class LearnedPredictor:
    """Base of the learned predictors: validation, dispatch, assembly (module docstring)."""

    mode = ""

    def __init__(self, bundle: Bundle):
        self.bundle = bundle
        self.pairs = [PairRuntime(models, bundle) for models in bundle.pairs.values()]
        self.table = PairTable([(p.size_a, p.size_b) for p in self.pairs])
        self.version = bundle.version

    def __call__(self, size_a, position_a, quaternion_a, size_b, position_b,
                 quaternion_b) -> ct.Contacts:
        values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
        one = single_pair(*values)
        if one is not None:
            return predict_one(self, one, spread=False)[0]
        return self._predict(values, spread=False).contacts

    def __repr__(self) -> str:
        return f"<{self.mode} predictor, bundle {self.version}>"

    def runtime(self, code: int) -> PairRuntime | None:
        """The pair of a dispatch code if it has this mode's models, else None."""
        if code == UNSUPPORTED:
            return None
        pair = self.pairs[code // 2]
        return pair if pair.supports(self.mode) else None

    def predict(self, size_a, position_a, quaternion_a, size_b, position_b,
                quaternion_b) -> Prediction:
        """Contacts of N pairs with the committee's spread; arguments as ``box_box``."""
        values = (size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
        one = single_pair(*values)
        if one is not None:
            contacts, normal_spread, point_spread = predict_one(self, one)
            return Prediction(contacts, np.array([normal_spread]), np.array([point_spread]))
        return self._predict(values, spread=True)

    def _predict(self, values, spread: bool) -> Prediction:
        """The batch path (module docstring, stages 1-4); the committee's spread is computed
        when ``spread``. Pairs without this mode's models raise UnsupportedPairError."""
        inputs = pc.checked_inputs(*values)
        out = self.answer(inputs, spread)
        if out.unsupported.any():
            raise UnsupportedPairError(np.flatnonzero(out.unsupported), [
                p.key for p in self.pairs if p.supports(self.mode)], self.mode)
        exact_fill(out, inputs, out.unknown)  # regions without a committee
        return out.prediction()

    def answer(self, inputs: pc.Inputs, spread: bool) -> Output:
        """Stages 2-3 of validated ``inputs``: every row this mode's models answer; the others
        flagged ``unsupported`` (no models for the pair) or ``unknown`` (no committee for the
        region), with ``unsure`` rows where ``spread`` and the pair's thresholds distrust the
        answer, for a caller (the strict mode, or the auto chain) to hand on."""
        out = Output(inputs.n)
        if inputs.n == 0:
            return out
        for code, rows in groups(self.table.match(inputs.size_a, inputs.size_b), inputs.n):
            pair = self.runtime(code)
            if pair is None:
                out.unsupported[slice(None) if rows is None else rows] = True
                continue
            if pair.exact_only:  # the bundle's decision: the exact solver answers this pair
                out.unknown[slice(None) if rows is None else rows] = True
                continue
            group = inputs if rows is None else inputs.take(rows)
            part = out if rows is None else Output(len(rows))
            self.solve(pair, group.swapped() if code % 2 else group, part, spread,
                       swapped=bool(code % 2))
            if code % 2:
                unswap_output(part)
            if rows is not None:
                out.put(rows, part)
        return out

    def solve(self, pair: PairRuntime, inputs: pc.Inputs, out: Output, spread: bool,
              swapped: bool = False) -> None:
        """Answer one pair model's rows into ``out`` (see the subclasses); ``inputs`` are in
        the bundle's order, ``swapped`` says that the request gave them the other way round."""
        raise NotImplementedError


def unswap_output(out: Output) -> None:
    """Flip a swapped group's answers back to the request's order (pair_dispatch.unswap)."""
    fields = {name: getattr(out, name) for name in ("normal", "feature_a", "feature_b",
                                                     "contact_type_code", "axis")}
    unswap(fields)
    for name, value in fields.items():
        setattr(out, name, value)


def exact_fill(out: Output, inputs: pc.Inputs, take: np.ndarray) -> None:
    """The exact solver answers the rows ``take`` (n,) bool, in one vectorised call."""
    rows = np.flatnonzero(take)
    if rows.size:
        out.put_exact(rows, box_box(*(a[rows] for a in inputs.full())))


class SinglePredictor(LearnedPredictor):
    """The paper's design, better posed: one MLP per pair from pose-v1 to contact-v1."""

    mode = "single"

    def solve(self, pair: PairRuntime, inputs: pc.Inputs, out: Output, spread: bool,
              swapped: bool = False) -> None:
        n = inputs.n
        features = _augmented_features(min(n, pc.ROW_BLOCK))
        outputs = np.empty((min(n, pc.ROW_BLOCK), 7), np.float32)
        for start in range(0, n, pc.ROW_BLOCK):
            stop = min(n, start + pc.ROW_BLOCK)
            x, y = features[:stop - start], outputs[:stop - start]
            frame = pc.canonical_block(inputs, start, stop, pair.inv_scale,
                                       x[:, :N_POSE_FEATURES])
            pair.single.forward_augmented(x, out=y)
            columns = np.ascontiguousarray(y.T)
            pc.world_block(columns, frame, pc.block_rows(inputs.position_a, start, stop),
                           pair.scale, out.point[start:stop], out.normal[start:stop])
            _depth(pair, columns[6], out.depth[start:stop])
            np.copyto(out.confidence[start:stop], pair.in_domain(columns[6]))
        out.finish_learned(self.mode)


def _augmented_features(rows: int) -> np.ndarray:
    """A (rows, 13) float32 buffer for pose-v1 features and the MLPs' column of ones."""
    features = np.empty((rows, N_POSE_FEATURES + 1), np.float32)
    features[:, N_POSE_FEATURES] = 1.0
    return features


def _depth(pair: PairRuntime, fraction: np.ndarray, depth: np.ndarray) -> None:
    """Depths (metres, clipped at 0) of predicted depth fractions of e, into ``depth``."""
    np.multiply(fraction, pair.edge, out=depth)
    np.maximum(depth, 0.0, out=depth)


#: Canonical outputs of a predicted "none" row before :func:`_separated` overwrites them.
_NONE_OUTPUT = np.array([0, 0, 0, *FALLBACK_NORMAL, 0], np.float32)


class CommitteePredictor(LearnedPredictor):
    """Exact region labels -> the region's committee, averaged; confidence and spread."""

    mode = "committee"

    def solve(self, pair: PairRuntime, inputs: pc.Inputs, out: Output, spread: bool,
              swapped: bool = False) -> None:
        n = inputs.n
        features = _augmented_features(n)
        request = inputs.swapped() if swapped else inputs  # labelled in the request's order
        region = np.empty(n, np.int16)
        unclipped = np.empty((n, 3))  # the labeller's point before clipping, world, metres
        untrusted = np.zeros(n, bool)  # rows auto answers exactly whatever the committee says
        frames = []
        for start in range(0, n, pc.ROW_BLOCK):
            stop = min(n, start + pc.ROW_BLOCK)
            frame = pc.canonical_block(inputs, start, stop, pair.inv_scale,
                                       features[start:stop, :N_POSE_FEATURES])
            frames.append(frame)
            labels = label_block(input_block(request, start, stop))
            labels = mirrored(labels) if swapped else labels
            region[start:stop] = _put_labels(pair, labels, frame, out, slice(start, stop))
            unclipped[start:stop] = labels.unclipped.T
            untrusted[start:stop] = (np.isin(labels.code, AUTO_EXACT_TYPES)
                                     & ~labels.exact_point & labels.colliding)
        unknown = region < 0  # a region without a committee: the exact solver answers
        np.maximum(region, 0, out=region)
        outputs = self._experts(pair, features, region, out, spread)
        scratch = np.empty((min(n, pc.ROW_BLOCK), 3))  # the experts' normals, not used
        for start, frame in zip(range(0, n, pc.ROW_BLOCK), frames):
            stop = min(n, start + pc.ROW_BLOCK)
            pc.world_block(outputs[:, start:stop], frame, unclipped[start:stop], pair.scale,
                           out.point[start:stop], scratch[:stop - start])
        out.confidence[:] = 1.0
        out.confidence[out.colliding & ~pair.in_domain(out.depth / pair.edge)] = 0.0
        _separated(out, inputs, np.flatnonzero(~out.colliding))
        if spread:  # the auto chain's question: which answers do the thresholds trust?
            out.unsure |= untrusted | (pair.unsure(
                out.confidence, out.normal_spread, out.point_spread, out.depth / pair.edge,
                out.colliding) if pair.auto is not None else True)
        out.finish_learned("committee")
        out.unknown |= unknown

    @staticmethod
    def _experts(pair: PairRuntime, features, region, out: Output, spread: bool) -> np.ndarray:
        """Committee means (7, n) float32, as columns; spreads into ``out``.

        Rows are sorted by region rank (regions with committees of equal size K adjacent);
        each region's committee runs once on its rows, each run of equal K gets its mean and
        spread in one pass.
        """
        n = len(region)
        key = pair.rank[region]
        order = np.argsort(key, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(np.bincount(key, minlength=len(pair.rank)))])
        ordered = features[order]
        outputs = np.empty((7, n), np.float32)  # in sorted order first
        normal_spread, point_spread = np.zeros(n, np.float32), np.zeros(n, np.float32)
        outputs[:, :bounds[1]] = _NONE_OUTPUT[:, None]
        for k, first, end in pair.k_groups:
            g0, g1 = bounds[first], bounds[end]
            if g1 == g0:
                continue
            members = np.empty((k, 7, g1 - g0), np.float32)
            for rank in range(first, end):
                b0, b1 = bounds[rank], bounds[rank + 1]
                if b1 > b0:
                    pair.experts[pair.by_rank[rank]].forward_columns(
                        ordered[b0:b1], out=members[:, :, b0 - g0:b1 - g0])
            member_stats(members, pair.scale, spread, out=(
                outputs[:, g0:g1], normal_spread[g0:g1], point_spread[g0:g1]))
        inverse = np.empty(n, np.intp)
        inverse[order] = np.arange(n)
        np.take(normal_spread, inverse, out=out.normal_spread)
        np.take(point_spread, inverse, out=out.point_spread)
        return np.take(outputs, inverse, axis=1)


def _put_labels(pair: PairRuntime, labels, frame, out: Output, rows: slice) -> np.ndarray:
    """The exact labels of a block into ``out[rows]``; returns the canonical region of each
    row (``pair.region_of``: -1 where the region has no committee; 0, whose outputs are a zero
    residual, for separated rows and rows whose unclipped point is exact)."""
    out.colliding[rows], out.axis[rows], out.depth[rows] = (labels.colliding, labels.axis,
                                                            labels.depth)
    out.normal[rows] = labels.normal.T
    out.contact_type_code[rows] = labels.code
    out.feature_a[rows], out.feature_b[rows] = labels.feature_a, labels.feature_b
    region = pair.region_of(labels.code, FLIP_FEATURES[frame.flip_a, labels.feature_a],
                            FLIP_FEATURES[frame.flip_b, labels.feature_b])
    region[labels.exact_point] = 0  # the unclipped point is exact: no committee, residual 0
    return region


def _separated(out: Output, inputs: pc.Inputs, rows: np.ndarray) -> None:
    """Separated rows: the point is the centres' midpoint (as the exact solver's)."""
    if rows.size:
        pa, pb = inputs.position_a, inputs.position_b
        pa, pb = (pa if len(pa) == 1 else pa[rows]), (pb if len(pb) == 1 else pb[rows])
        out.point[rows] = 0.5 * (pa + pb)
