"""The learned predictors ``single`` and ``committee`` (docs/learned_predictors.md); ``auto``
is the chain of :mod:`impactnet.models.learned.chain`, the committee then the exact solver.

Each is a callable with :func:`impactnet.models.box.exact.box_box`'s signature returning
`Contacts` with ``confidence`` and ``predictor`` filled; :meth:`LearnedPredictor.predict` also
returns the committee's spread. The work is one compiled row function
(:func:`impactnet.models.learned.kernel_pair.answer_row`), the same for one pair and for every
row of a batch, so a pair gets the same answer to the last bit alone or in a batch. This
module is the thin layer around it:

1. Dispatch (:mod:`impactnet.models.learned.pair_dispatch`): a request's rows are grouped by
   the pair model their sizes match (a loop over groups, not rows); rows of a swapped pair are
   solved swapped and flipped back in the kernel. Each group runs in the mode of its pair
   (:meth:`LearnedPredictor.route`): this predictor's, or ``exact`` where the bundle serves
   the pair exact-only (its ``decision``, issue #21); rows of a pair without this mode's
   models are *unsupported*: the strict modes raise :class:`UnsupportedPairError`, ``auto``
   answers them exactly.
2. One pair of six float64 vectors (a simulator's call) goes straight to the one-pair entry
   (:func:`impactnet.models.learned.pair_entry.one_pair_entry`: the inputs checked in the
   kernel); anything else is checked as the exact solver checks it (same errors) and each
   group runs over its rows, serially or over the kernel threads in chunks
   (:func:`impactnet.models.learned.kernel_mlp.run_rows`).

Fields of a learned answer: ``single`` predicts no contact type, so its rows have
``colliding`` True, ``contact_type_code`` 0 and features / axis -1 (not predicted), and
confidence 1 inside the trained depth domain, 0 outside it (it has no uncertainty estimate).
``committee`` takes colliding, type, features, axis, normal and depth from the region
classifier (they equal the exact solver's) and the point from the experts; confidence is 1, 0
where the depth leaves the trained domain; a separated row is answered as the exact solver
answers it (point: the centres' midpoint); a region without a committee is answered by the
exact solver (``predictor`` "exact"). The manifold of a learned contact is its point (count 1).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from impactnet.models.box import kernels as box_kernels
from impactnet.models.box.exact import _vectors, box_box, checked_rows, fault_error
from impactnet.models.box.kernel_inputs import first_fault
from impactnet.models.contacts import MAX_MANIFOLD_POINTS, Contacts
from impactnet.models.learned import kernel_pair as kp
from impactnet.models.learned.bundle_loader import Bundle
from impactnet.models.learned.kernel_mlp import run_rows
from impactnet.models.learned.pair_dispatch import (
    UNSUPPORTED,
    PairTable,
    UnsupportedPairError,
    groups,
)
from impactnet.models.learned.pair_entry import NO_PROGRAM, one_pair_entry
from impactnet.models.learned.pair_runtime import PairRuntime

_ND, _SEQUENCES = np.ndarray, (list, tuple)
_F64, _BOOL, _INT8 = np.dtype(np.float64), np.dtype(np.bool_), np.dtype(np.int8)
_ONE, _ONE_3, _ONE_M3, _ONE_M, _EXTRAS = (1,), (1, 3), (1, MAX_MANIFOLD_POINTS, 3), (
    1, MAX_MANIFOLD_POINTS), (len(kp.EXTRAS), 1)
_NAMES = tuple(name for name, _, _ in box_kernels.OUTPUTS)
_EXACT = np.array(["exact"])
_empty, _new = np.empty, object.__new__


class Prediction(NamedTuple):
    """A predictor's answer and the committee's spread (0 where no committee answered)."""

    contacts: Contacts
    normal_spread: np.ndarray  # (n,) degrees, largest angle between member normals
    point_spread: np.ndarray  # (n,) metres, largest distance between member points


def _contacts(out, confidence: np.ndarray, predictor: np.ndarray) -> Contacts:
    """The `Contacts` around the kernel's 12 output arrays (``out``, :data:`_NAMES` order)."""
    contacts = _new(Contacts)
    (colliding, normal, depth, point, code, feature_a, feature_b, axis, points, depths, count,
     pressure) = out
    contacts.__dict__ = {
        "colliding": colliding, "normal": normal, "depth": depth, "point": point,
        "contact_type_code": code, "feature_a": feature_a, "feature_b": feature_b,
        "axis": axis, "manifold_points": points, "manifold_depths": depths,
        "manifold_count": count, "confidence": confidence, "predictor": predictor,
        "pressure": pressure}
    return contacts


class LearnedPredictor:
    """Base of the learned predictors: dispatch and the kernel's entries (module docstring)."""

    mode = ""  # the predictor's name: "single", "committee" or "auto"
    kernel_mode = kp.EXACT  # its rows' mode in the kernel
    answered_by = ""  # the ``predictor`` name of its learned rows

    def __init__(self, bundle: Bundle, pairs: list[PairRuntime] | None = None):
        self.bundle = bundle
        self.pairs = pairs if pairs is not None else [PairRuntime(models, bundle)
                                                      for models in bundle.pairs.values()]
        self.table = PairTable([(p.size_a, p.size_b) for p in self.pairs])
        self.version = bundle.version
        self._routes = {code: self.route(code) for code in range(-1, 2 * len(self.pairs))}
        self._learned_name = np.array([self.answered_by])

    def __repr__(self) -> str:
        return f"<{self.mode} predictor, bundle {self.version}>"

    def route(self, code: int) -> tuple[int, tuple | None]:
        """(kernel mode, pair program) of a dispatch code: this predictor's mode where the pair
        has its models, ``exact`` for an exact-only pair (and in ``auto`` for a pair without
        models), -1 for rows this strict mode cannot answer."""
        if code != UNSUPPORTED:
            pair = self.pairs[code // 2]
            if pair.exact_only:
                return kp.EXACT, NO_PROGRAM
            if pair.supports(self.mode):
                return self.kernel_mode, pair.program
        return (kp.EXACT, NO_PROGRAM) if self.mode == "auto" else (-1, None)

    def __call__(self, size_a, position_a, quaternion_a, size_b, position_b,
                 quaternion_b) -> Contacts:
        return self._answer((size_a, position_a, quaternion_a, size_b, position_b,
                             quaternion_b))[0]

    def predict(self, size_a, position_a, quaternion_a, size_b, position_b,
                quaternion_b) -> Prediction:
        """Contacts of N pairs with the committee's spread; arguments and errors as
        ``box_box``'s, and UnsupportedPairError for rows of a pair without this mode's models
        (strict modes)."""
        contacts, extras = self._answer((size_a, position_a, quaternion_a, size_b, position_b,
                                         quaternion_b))
        if extras is None:  # the exact solver answered alone
            return Prediction(contacts, np.zeros(len(contacts)), np.zeros(len(contacts)))
        return Prediction(contacts, extras[kp.NORMAL_SPREAD], extras[kp.POINT_SPREAD])

    def _answer(self, values) -> tuple[Contacts, np.ndarray | None]:
        """(Contacts, the kernel's ``extras`` or None) of the six inputs (module docstring)."""
        if type(values[0]) is not _ND and type(values[0]) in _SEQUENCES:  # one pair as lists
            values = _vectors(*values)
        if type(values[0]) is _ND and values[0].ndim == 1:
            answer = self._one(values)
            if answer is not None:
                return answer
        return self._batch(values)

    def _one(self, values):
        """One pair of (w,) vectors through the one-pair entry; None where it does not apply
        (another input type, unsupported sizes, an input fault: the batch path raises)."""
        code = self.table.match_one(values[0].tolist(), values[3].tolist())
        mode, program = self._routes[code]
        if mode < 0:
            return None
        if mode == kp.EXACT:
            return box_box(*values), None
        e = _empty
        out = (e(_ONE, _BOOL), e(_ONE_3, _F64), e(_ONE, _F64), e(_ONE_3, _F64), e(_ONE, _INT8),
               e(_ONE, _INT8), e(_ONE, _INT8), e(_ONE, _INT8), e(_ONE_M3, _F64),
               e(_ONE_M, _F64), e(_ONE, _INT8), e(_ONE, _F64))
        extras = e(_EXTRAS, _F64)
        try:
            fault = (_entry or _one_pair())(*values, *program, mode, code % 2 == 1, *out, extras)
        except TypeError:  # not six float64 vectors
            return None
        if fault:
            return None
        name = _EXACT if extras[kp.ANSWERED_EXACTLY, 0] else self._learned_name
        return _contacts(out, extras[kp.CONFIDENCE], name.copy()), extras

    def _batch(self, values) -> tuple[Contacts, np.ndarray]:
        """Any number of pairs: checked, grouped by pair, each group's rows in its mode."""
        rows, n = checked_rows(*values)
        fault = first_fault(*rows, n)
        if fault:
            raise fault_error(fault, rows, n)
        out = tuple(box_kernels.output_arrays(n))
        extras = np.empty((len(kp.EXTRAS), n))
        routed = [(code, index, *self._routes[code])
                  for code, index in groups(self.table.match(rows[0], rows[3]), n)] if n else []
        refused = [np.arange(n) if index is None else index
                   for _, index, mode, _ in routed if mode < 0]
        if refused:
            raise UnsupportedPairError(np.sort(np.concatenate(refused)), [
                p.key for p in self.pairs if p.supports(self.mode)], self.mode)
        for code, index, mode, program in routed:
            index = np.arange(n) if index is None else index
            run_rows(kp.answer_rows, kp.answer_rows_parallel, len(index), tuple(rows), index,
                     *program, mode, code % 2 == 1, out, extras)
        exact = extras[kp.ANSWERED_EXACTLY] > 0.0
        return _contacts(out, extras[kp.CONFIDENCE],
                         np.where(exact, "exact", self.answered_by)), extras


#: The one-pair entry once closed (:func:`impactnet.models.learned.pair_entry.one_pair_entry`).
_entry = None


def _one_pair():
    global _entry
    _entry = one_pair_entry()
    return _entry


class SinglePredictor(LearnedPredictor):
    """The paper's design, better posed: one MLP per pair from pose-v1 to contact-v1."""

    mode, kernel_mode, answered_by = "single", kp.SINGLE, "single"


class CommitteePredictor(LearnedPredictor):
    """Exact region labels -> the region's committee, averaged; confidence and spread."""

    mode, kernel_mode, answered_by = "committee", kp.COMMITTEE, "committee"
