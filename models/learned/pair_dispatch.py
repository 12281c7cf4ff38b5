"""Which of a bundle's pair models answers a request, by the boxes' sizes.

A request whose sizes match a pair ``a/b`` (each size within ``SIZE_REL_TOL`` of the larger,
per component) uses that pair's models; one matching ``b/a`` is solved swapped and flipped
back (Jolt's reversed dispatch: :func:`unswap`); anything else is *unsupported*.

Codes: a row's dispatch code is ``2 k + swapped`` for pair k, or :data:`UNSUPPORTED`.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from impactnet.models.geometry.box_features import SIZE_REL_TOL

UNSUPPORTED = -1
#: Contact type code of the swapped pair: vertex-face <-> face-vertex, edge-face <->
#: face-edge; none, edge-edge and face-face map to themselves.
MIRROR_TYPE = np.array([0, 2, 1, 3, 5, 4, 6], np.int8)
#: Axis id of the swapped pair (index -1, the last entry, keeps "no axis"): A's face axes
#: 0-2 <-> B's 3-5; cross axis 6 + 3 i + j <-> 6 + 3 j + i.
MIRROR_AXIS = np.array([3, 4, 5, 0, 1, 2] + [6 + 3 * (c % 3) + c // 3 for c in range(9)]
                       + [-1], np.int8)


class UnsupportedPairError(ValueError):
    """Rows whose box sizes match no pair model of the bundle; ``rows`` lists them."""

    def __init__(self, rows, pairs: Sequence[str], mode: str):
        self.rows = np.asarray(rows).tolist()
        self.pairs = tuple(pairs)  # the bundle pairs this mode has models for
        super().__init__(
            f"mode {mode!r} has no model for the box sizes of rows {self.rows[:10]}"
            f"{' ...' if len(self.rows) > 10 else ''} (pairs with models: "
            f"{', '.join(pairs)}); use mode 'auto' or 'exact' for other boxes")


def _same(a, b, rel_tol: float) -> bool:
    return all(abs(x - y) <= rel_tol * max(abs(x), abs(y)) for x, y in zip(a, b))


class PairTable:
    """Size matching of the pairs ``sizes[k] = (size_a, size_b)`` (metres), built once."""

    def __init__(self, sizes: Sequence[tuple[Sequence[float], Sequence[float]]],
                 rel_tol: float = SIZE_REL_TOL):
        self.rel_tol = rel_tol
        self.bodies: list[tuple[float, ...]] = []
        self.exact: dict[tuple, int] = {}  # (size_a, size_b) as float tuples -> code
        index = []
        for size_a, size_b in sizes:
            index.append((self._body(size_a), self._body(size_b)))
        n_bodies = len(self.bodies)
        self.codes = np.full((n_bodies + 1, n_bodies + 1), UNSUPPORTED, np.int64)  # -1: none
        for k, (i, j) in reversed(list(enumerate(index))):  # the first pair wins a clash
            self.codes[j, i] = 2 * k + 1
        for k, (i, j) in reversed(list(enumerate(index))):
            self.codes[i, j] = 2 * k
        for i, a in enumerate(self.bodies):
            for j, b in enumerate(self.bodies):
                if self.codes[i, j] != UNSUPPORTED:
                    self.exact[(a, b)] = int(self.codes[i, j])
        self._body_array = np.array(self.bodies).reshape(-1, 3)

    def _body(self, size) -> int:
        size = tuple(float(v) for v in size)
        for i, body in enumerate(self.bodies):
            if _same(body, size, self.rel_tol):
                return i
        self.bodies.append(size)
        return len(self.bodies) - 1

    def match_one(self, size_a: Sequence[float], size_b: Sequence[float]) -> int:
        """Dispatch code of one pair of sizes (lists of floats)."""
        code = self.exact.get((tuple(size_a), tuple(size_b)))
        if code is not None:
            return code
        return int(self.codes[self._body_one(size_a), self._body_one(size_b)])

    def _body_one(self, size) -> int:
        for i, body in enumerate(self.bodies):
            if _same(body, size, self.rel_tol):
                return i
        return -1

    def body_index(self, sizes: np.ndarray) -> np.ndarray:
        """Body index (m,) of each row of sizes (m, 3), -1 for none.

        Rows equal to a body's sizes bit for bit (what a simulator sends) are matched by three
        equality tests per body; only the others take the tolerance test.
        """
        out = np.full(len(sizes), -1, np.int64)
        columns = sizes.T
        for i, body in enumerate(self._body_array.tolist()):
            hit = (columns[0] == body[0]) & (columns[1] == body[1]) & (columns[2] == body[2])
            out[hit & (out < 0)] = i
        rest = np.flatnonzero(out < 0)
        if rest.size:
            near = sizes[rest]
            for i, body in enumerate(self._body_array):
                tol = self.rel_tol * np.maximum(np.abs(near), body)
                hit = (np.abs(near - body) <= tol).all(axis=1) & (out[rest] < 0)
                out[rest[hit]] = i
        return out

    def match(self, size_a: np.ndarray, size_b: np.ndarray) -> np.ndarray | int:
        """Dispatch codes of (1|n, 3) size arrays: an int when every row has the same sizes
        (bit for bit), else an (n,) int64 array."""
        one_a, one_b = _uniform(size_a), _uniform(size_b)
        if one_a and one_b:
            return self.match_one(size_a[0].tolist(), size_b[0].tolist())
        index_a = self.body_index(size_a[:1] if one_a else size_a)
        index_b = self.body_index(size_b[:1] if one_b else size_b)
        return self.codes[index_a, index_b]


def _uniform(sizes: np.ndarray) -> bool:
    return len(sizes) == 1 or bool((sizes == sizes[0]).all())


def groups(codes: np.ndarray | int, n: int) -> list[tuple[int, np.ndarray | None]]:
    """``(code, rows)`` per dispatch code present (rows None: all n rows), in code order."""
    if np.ndim(codes) == 0:
        return [(int(codes), None)]
    present = np.flatnonzero(np.bincount(codes + 1))
    if len(present) == 1:
        return [(int(present[0]) - 1, None)]
    return [(int(c) - 1, np.flatnonzero(codes == c - 1)) for c in present]


def unswap(fields: dict) -> None:
    """Turn a swapped pair's answer (B, A) into the answer for (A, B), in place.

    ``fields`` holds ``normal`` (m, 3) (negated), ``feature_a`` / ``feature_b`` (exchanged),
    ``contact_type_code`` and ``axis`` (mirrored); points and depths are unchanged.
    """
    np.negative(fields["normal"], out=fields["normal"])
    fields["feature_a"], fields["feature_b"] = fields["feature_b"], fields["feature_a"]
    fields["contact_type_code"] = MIRROR_TYPE[fields["contact_type_code"]]
    fields["axis"] = MIRROR_AXIS[fields["axis"]]
