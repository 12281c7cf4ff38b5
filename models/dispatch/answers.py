"""The one answer of N pairs of bodies, box or compound (issue #33): body-level columns and the
ragged list of part contacts, gathered slice by slice.

A box is a body of one part, so a box pair's answer has the same fields as a compound pair's:
body level, per row ``i`` (``n`` rows): ``colliding``, ``point``, ``normal``, ``depth``,
``contact_type`` (code), ``feature_a`` / ``feature_b`` and ``part_a`` / ``part_b`` of the
deepest part contact (-1 without contact), ``cluster_size``, ``confidence`` and ``predictor``
(code); per part contact (``m`` rows, row ``i``'s at ``offsets[i]:offsets[i + 1]``, the deepest
first): :data:`CONTACT_COLUMNS`, with the manifold where asked. Part names and predictors are
codes into small tables (:attr:`Answers.part_names`, :attr:`Answers.predictor_names`), so that
a million part contacts hold ~90 bytes each; the service's encoders turn codes into names a
piece at a time.

A separated pair's ``normal`` is the separating direction of its closest part pair (never
zero; a box pair's: the separating axis of largest separation), its ``point`` the midpoint
between them. ``distance`` is ``-depth`` for a pair in contact, the gap (> 0) for a pair
apart by less than the request's margin, and infinite beyond it; within the margin ``point``
is the closest region's centroid (the midpoint of the closest points where they are unique),
``closest_a`` / ``closest_b`` the centroids of the closest regions on A and on B (NaN beyond
the margin and in contact), and ``part_a`` / ``part_b`` the closest part pair.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES, MAX_MANIFOLD_POINTS

#: Per-contact columns: (name, dtype, row shape).
CONTACT_COLUMNS = (("part_a", np.int32, ()), ("part_b", np.int32, ()),
                   ("point", np.float64, (3,)), ("normal", np.float64, (3,)),
                   ("depth", np.float64, ()), ("contact_type", np.int8, ()),
                   ("feature_a", np.int32, ()), ("feature_b", np.int32, ()),
                   ("axis", np.int8, ()), ("pressure", np.float64, ()))
#: The manifold's columns, carried only when asked (``include=manifold``).
MANIFOLD_COLUMNS = (("manifold_count", np.int8, ()),
                    ("manifold_points", np.float64, (MAX_MANIFOLD_POINTS, 3)),
                    ("manifold_depths", np.float64, (MAX_MANIFOLD_POINTS,)))
#: Body-level columns: (name, dtype, row shape, value of a row never solved).
BODY_COLUMNS = (("colliding", np.bool_, (), False), ("point", np.float64, (3,), 0.0),
                ("normal", np.float64, (3,), 0.0), ("depth", np.float64, (), 0.0),
                ("contact_type", np.int8, (), 0), ("feature_a", np.int32, (), -1),
                ("feature_b", np.int32, (), -1), ("part_a", np.int32, (), -1),
                ("part_b", np.int32, (), -1), ("cluster_size", np.int64, (), 0),
                ("confidence", np.float64, (), 1.0), ("distance", np.float64, (), np.inf),
                ("closest_a", np.float64, (3,), np.nan), ("closest_b", np.float64, (3,), np.nan))
#: The key of every box shape's part code (:meth:`Pieces.codes_of`).
BOX_KEY = "box"
#: Contact types by code.
CONTACT_NAMES = np.asarray(CONTACT_TYPES)


@dataclass(frozen=True)
class Answers:
    """The answers of n pairs (module docstring)."""

    body: dict  # name -> (n, ...) array, BODY_COLUMNS
    predictor: np.ndarray  # (n,) int8 codes into predictor_names
    predictor_names: np.ndarray  # (p,) str
    offsets: np.ndarray  # (n + 1,) int64
    contacts: dict  # name -> (m, ...) array, CONTACT_COLUMNS (+ MANIFOLD_COLUMNS if asked)
    part_names: np.ndarray  # (q,) str: the names of part codes
    shapes: tuple  # the shape (a Shape) of each part code's body, for feature names
    part_index: np.ndarray  # (q,) int64: each part code's index among its shape's parts

    def __len__(self) -> int:
        return len(self.predictor)

    def take(self, rows: np.ndarray) -> Answers:
        """The answers of ``rows`` (k,) (sorted, distinct), their part contacts with them."""
        rows = np.asarray(rows, np.int64)
        counts = (self.offsets[1:] - self.offsets[:-1])[rows]
        offsets = np.zeros(len(rows) + 1, np.int64)
        np.cumsum(counts, out=offsets[1:])
        # the part contacts of the kept rows: each row's run, in order
        starts = np.repeat(self.offsets[rows] - offsets[:-1], counts)
        picked = starts + np.arange(offsets[-1])
        return Answers({k: v[rows] for k, v in self.body.items()}, self.predictor[rows],
                       self.predictor_names, offsets,
                       {k: v[picked] for k, v in self.contacts.items()}, self.part_names,
                       self.shapes, self.part_index)

    def predictor_of(self, i: int) -> str:
        return str(self.predictor_names[self.predictor[i]])


class _BodyColumns(dict):
    """Body-level columns (:data:`BODY_COLUMNS`) of n rows, each made when first read or
    written: a column that one slice fills whole is that slice's array, never copied into one
    filled first (a single pair's answer would otherwise allocate and fill them all)."""

    _SPEC = {name: (dtype, shape, fill) for name, dtype, shape, fill in BODY_COLUMNS}

    def __init__(self, n: int) -> None:
        super().__init__()
        self.n = n

    def __missing__(self, name: str) -> np.ndarray:
        dtype, shape, fill = self._SPEC[name]
        column = self[name] = np.full((self.n, *shape), fill, dtype)
        return column

    def put(self, name: str, rows: np.ndarray, values) -> None:
        """Column ``name`` at ``rows`` (k,) (distinct) = ``values`` (k, ...)."""
        if name not in self and len(rows) == self.n and (
                self.n == 1 or bool((rows[1:] > rows[:-1]).all())):  # every row, in order
            dtype, shape, _ = self._SPEC[name]
            whole = values if type(values) is np.ndarray and values.dtype == dtype else \
                np.asarray(values, dtype)
            if whole.shape == (self.n, *shape) and whole.flags.writeable:
                self[name] = whole
                return
        self[name][rows] = values


class Pieces:
    """Answers of slices of rows, merged once at the end (:meth:`merged`)."""

    def __init__(self, n: int, manifold: bool = False) -> None:
        self.n, self.manifold = n, manifold
        self.body = _BodyColumns(n)
        self.predictor = np.zeros(n, np.int8)
        self.predictor_names: list[str] = ["exact"]
        self.part_names: list[str] = []
        self.shapes: list = []
        self.part_index: list[int] = []
        self._codes: dict[int, np.ndarray] = {}
        self.rows: list[np.ndarray] = []
        self.columns: list[dict] = []
        self.contacts = 0

    def codes_of(self, shape) -> np.ndarray:
        """The codes of a body shape's part names (each shape's names added once; every box
        shares one code, its part ``box``: a box's features are named alike whatever its size,
        so a batch of many box sizes adds one name, not one per size)."""
        key = BOX_KEY if shape.is_box else id(shape)
        if key not in self._codes:
            start = len(self.part_names)
            self.part_names += list(shape.part_names)
            self.shapes += [shape] * len(shape.part_names)
            self.part_index += list(range(len(shape.part_names)))
            self._codes[key] = np.arange(start, start + len(shape.part_names), dtype=np.int32)
        return self._codes[key]

    def predictor_codes(self, names) -> np.ndarray:
        """Codes (k,) of predictor names (k,) or of one name."""
        if type(names) is not np.ndarray or names.ndim != 1:
            names = np.atleast_1d(np.asarray(names))
        if not len(names):
            return np.zeros(0, np.int8)
        if len(names) == 1 or (names == names[0]).all():  # one predictor: no sort
            name = str(names[0])
            if name not in self.predictor_names:
                self.predictor_names.append(name)
            return np.full(len(names), self.predictor_names.index(name), np.int8)
        unique, inverse = np.unique(names, return_inverse=True)
        for name in unique.tolist():
            if name not in self.predictor_names:
                self.predictor_names.append(name)
        lookup = np.array([self.predictor_names.index(u) for u in unique.tolist()], np.int8)
        return lookup[inverse.reshape(-1)]

    def add(self, rows: np.ndarray, body: dict, predictor, contact_rows: np.ndarray,
            columns: dict) -> None:
        """One slice: its request rows (k,), body-level values (name -> (k, ...)), predictor
        names, and its part contacts: their request rows (c,) and columns (name -> (c, ...)).
        The arrays are handed over: a body column that this slice fills whole is kept as
        given, so a caller passes arrays it does not use again."""
        for name, values in body.items():
            self.body.put(name, rows, values)
        self.predictor[rows] = self.predictor_codes(predictor)
        self.rows.append(np.asarray(contact_rows, np.int64))
        self.columns.append(columns)
        self.contacts += len(contact_rows)

    def merged(self) -> Answers:
        """The answers, part contacts in row order (request order, then the deepest first)."""
        row = (self.rows[0] if len(self.rows) == 1 else np.concatenate(self.rows) if self.rows
               else np.zeros(0, np.int64))
        # rows in request order, the deepest first; already so where every row has at most
        # one contact and they come in order (box pairs)
        ordered = len(row) < 2 or bool((row[1:] > row[:-1]).all())
        order = None if ordered else np.lexsort(
            (-np.concatenate([c["depth"] for c in self.columns]), row))
        wanted = CONTACT_COLUMNS + (MANIFOLD_COLUMNS if self.manifold else ())
        contacts = {}
        for name, dtype, shape in wanted:
            parts = [c.pop(name) for c in self.columns]
            column = (parts[0] if len(parts) == 1 else np.concatenate(parts) if parts
                      else np.zeros((0, *shape), dtype))
            column = column if order is None else column[order]
            contacts[name] = column.astype(dtype, copy=False)
        offsets = np.zeros(self.n + 1, np.int64)
        np.cumsum(np.bincount(row, minlength=self.n), out=offsets[1:])
        self.rows, self.columns = [], []
        body = {name: self.body[name] for name, *_ in BODY_COLUMNS}
        return Answers(body, self.predictor, np.asarray(self.predictor_names), offsets,
                       contacts, np.asarray(self.part_names, dtype=str), tuple(self.shapes),
                       np.asarray(self.part_index, np.int64))
