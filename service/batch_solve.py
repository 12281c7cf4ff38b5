"""A batch solved in chunks, straight into the answer's arrays, within the request's memory lease.

The predictors answer N pairs at once, but their working set grows with N (temporaries of the
separating-axis test, the clip, the experts, and the full
:class:`impactnet.models.contacts.Contacts`):
up to ~3.3 KB per pair in mode ``exact`` and ~1.8 KB in ``auto``, against the answer's 70-360
bytes per pair. So the pairs are solved :data:`CHUNK_ROWS` at a time, and each chunk's answer is
written into arrays allocated once for the whole batch (:data:`ANSWER_LAYOUT`): the batch
needs its answer plus one chunk's working set, both reserved before the solve starts.

Manifold depths are clamped to >= 0 like ``depth``: exactly touching boxes give -1e-17 from
round-off, which reads as "separated" to a client that tests the sign.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.work import checkpoint
from impactnet.service.codecs.pairs import paper_angles, predict_checked
from impactnet.service.errors import UnsupportedPair
from impactnet.service.limits.budget import Lease
from impactnet.service.predictors import PairInputs

#: Rows per predictor call. The chunk's working set (below) stays ~16 MiB, and the per-call cost
#: of the predictors (~0.1 ms) stays far below a chunk's solve (~5-15 ms).
CHUNK_ROWS = 4096
#: Upper bound of a predictor's working set per row of a chunk, bytes, the chunk's Contacts
#: included: tracemalloc peaks of 8,192-row calls were 3,310 (exact, centre-of-pressure rule,
#: every row colliding; 1,924 with a quarter separated) and, with the shipped bundle before
#: that rule, 520 (single), 570 (committee), 1,722 (auto).
SOLVE_BYTES_PER_ROW = 4096
#: Upper bound of the validated inputs per pair, bytes (:class:`PairInputs`: sizes, positions
#: and quaternions of both bodies in float64, object indices, the float64 copies of integer
#: columns and the rotation conversion's temporaries): tracemalloc peaks of 100,000-pair
#: batches were 80 (quaternions), 400 (int8 Euler angles) and 456 (matrices and names).
PAIR_INPUT_BYTES = 512
#: The answer's arrays: name -> (dtype, shape of one row, the ``include`` that adds it).
ANSWER_LAYOUT = {
    "colliding": (np.bool_, (), None),
    "point": ("<f8", (3,), None),
    "normal": ("<f8", (3,), None),
    "depth": ("<f8", (), None),
    "contact_type_code": (np.int8, (), None),
    "feature_a": (np.int8, (), None),
    "feature_b": (np.int8, (), None),
    "axis": (np.int8, (), None),
    "confidence": ("<f8", (), None),
    "predictor_code": (np.int8, (), None),
    "manifold_count": (np.int8, (), "manifold"),
    "manifold_points": ("<f8", (8, 3), "manifold"),
    "manifold_depths": ("<f8", (8,), "manifold"),
    "paper_angles": ("<f8", (4,), "paper_angles"),
}
#: Answer columns copied from the :class:`Contacts` field of the same name.
_COPIED = ("colliding", "point", "normal", "depth", "contact_type_code", "feature_a",
           "feature_b", "axis", "confidence", "manifold_count", "manifold_points")


def _layout(include) -> dict:
    return {k: v for k, v in ANSWER_LAYOUT.items() if v[2] is None or v[2] in include}


def answer_bytes(n: int, include) -> int:
    """Bytes of the answer's arrays for ``n`` pairs."""
    return sum(n * np.dtype(dtype).itemsize * int(np.prod(shape))
               for dtype, shape, _ in _layout(include).values())


def _chunk(pairs: PairInputs, start: int, stop: int) -> PairInputs:
    return PairInputs(*(getattr(pairs, f)[start:stop] for f in PairInputs.__dataclass_fields__))


class _Predictors:
    """Global codes of the predictor names met in the chunks, sorted at the end."""

    def __init__(self) -> None:
        self.names: list[str] = []

    def codes(self, predictor: np.ndarray) -> np.ndarray:
        if len(predictor) and (predictor == predictor[0]).all():
            names, inverse = predictor[:1], np.zeros(len(predictor), np.intp)
        else:
            names, inverse = np.unique(predictor, return_inverse=True)
        for name in names.tolist():
            if name not in self.names:
                self.names.append(name)
        lookup = np.array([self.names.index(name) for name in names.tolist()], np.int8)
        return lookup[inverse.reshape(-1)]

    def finish(self, codes: np.ndarray) -> np.ndarray:
        """The sorted names; ``codes`` are renumbered in place."""
        order = np.argsort(self.names)
        renumber = np.empty(len(order), np.int8)
        renumber[order] = np.arange(len(order), dtype=np.int8)
        codes[:] = renumber[codes]
        return np.asarray(self.names)[order].astype(str)


def _fill(out: dict, contacts, pairs: PairInputs, start: int, stop: int) -> None:
    for name in _COPIED:
        if name in out:
            out[name][start:stop] = getattr(contacts, name)
    if "manifold_depths" in out:
        np.maximum(contacts.manifold_depths, 0.0, out=out["manifold_depths"][start:stop])
        out["manifold_depths"][start:stop] += 0.0  # -0.0 -> 0.0
    if "paper_angles" in out:
        out["paper_angles"][start:stop] = paper_angles(contacts, pairs)


def solve_batch(predictor, pairs: PairInputs, include, lease: Lease) -> dict:
    """The answer's arrays (:data:`ANSWER_LAYOUT`, plus ``predictor_names``) for all pairs.

    Raises UnsupportedPair (422) naming every unsupported row of a strict learned mode,
    InputError (422) and Overloaded (503, no room in the memory budget).
    """
    n = len(pairs)
    lease.reserve(answer_bytes(n, include) + min(n, CHUNK_ROWS) * SOLVE_BYTES_PER_ROW,
                  f"solving {n} pairs")
    out = {k: np.empty((n, *shape), dtype) for k, (dtype, shape, _) in _layout(include).items()}
    names, unsupported, covered = _Predictors(), [], []
    for start in range(0, n, CHUNK_ROWS):
        checkpoint()  # the request's deadline and its client (impactnet.models.work)
        stop = min(n, start + CHUNK_ROWS)
        chunk = _chunk(pairs, start, stop) if (start, stop) != (0, n) else pairs
        try:
            contacts = predict_checked(predictor, chunk, batch=True, offset=start)
        except UnsupportedPair as exc:  # go on: the error names every such row
            unsupported += exc.rows
            covered = exc.covered
            continue
        if not unsupported:
            _fill(out, contacts, chunk, start, stop)
            out["predictor_code"][start:stop] = names.codes(contacts.predictor)
    if unsupported:
        raise UnsupportedPair(predictor.mode, unsupported, covered, True)
    out["predictor_names"] = names.finish(out["predictor_code"])
    return out
