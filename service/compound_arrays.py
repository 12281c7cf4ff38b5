"""The answer of a compound request as compact arrays, gathered slice by slice.

Rows are the request's rows (``n``); part contacts are ragged, pose-major, row ``i``'s at
``offsets[i]:offsets[i + 1]``. Part names are codes into :attr:`CompoundArrays.part_names`
(every group's parts once), contact types and predictors codes into their tables, so that an
answer of a million part contacts holds ~84 bytes each; the encoders
(:mod:`impactnet.service.codecs.compound_encode`) turn codes into names a piece at a time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES

#: Per-contact columns, in the answer's order: (name, dtype, row shape).
CONTACT_COLUMNS = (("part_a", np.int32, ()), ("part_b", np.int32, ()),
                   ("point", np.float64, (3,)), ("normal", np.float64, (3,)),
                   ("depth", np.float64, ()), ("contact_type", np.int8, ()),
                   ("feature_a", np.int32, ()), ("feature_b", np.int32, ()),
                   ("pressure", np.float64, ()))
#: Contact types by code (``contact_type``'s table).
CONTACT_NAMES = np.asarray(CONTACT_TYPES)


@dataclass(frozen=True)
class CompoundArrays:
    """The answer of n compound rows."""

    colliding: np.ndarray  # (n,) bool
    point: np.ndarray  # (n, 3) metres, world frame
    normal: np.ndarray  # (n, 3) unit, from A towards B (zeros where there is no contact)
    depth: np.ndarray  # (n,) metres
    cluster_size: np.ndarray  # (n,) int64, part contacts in the summary's cluster
    predictor: np.ndarray  # (n,) int8 codes into predictor_names
    predictor_names: np.ndarray  # (p,) str
    offsets: np.ndarray  # (n + 1,) int64
    contacts: dict  # name -> (m, ...) array, CONTACT_COLUMNS
    part_names: np.ndarray  # (q,) str: names of part codes

    def __len__(self) -> int:
        return len(self.depth)


class Pieces:
    """The slices' answers of one request, merged once at the end (:meth:`merged`)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.summary = {"colliding": np.zeros(n, bool), "point": np.zeros((n, 3)),
                        "normal": np.zeros((n, 3)), "depth": np.zeros(n),
                        "cluster_size": np.zeros(n, np.int64)}
        self.predictor = np.zeros(n, np.int8)  # code 0: the oracle (rows never solved)
        self.predictor_names = ["oracle"]
        self.part_names: list[str] = []
        self._codes: dict[int, np.ndarray] = {}
        self.rows: list[np.ndarray] = []
        self.columns: list[dict] = []
        self.contacts = 0

    def names_of(self, parts_a, parts_b) -> tuple[np.ndarray, np.ndarray]:
        """Codes of A's and B's part names (each body's names added once)."""
        codes = []
        for parts in (parts_a, parts_b):
            key = id(parts)
            if key not in self._codes:
                start = len(self.part_names)
                self.part_names += [p.name for p in parts]
                self._codes[key] = np.arange(start, start + len(parts), dtype=np.int32)
            codes.append(self._codes[key])
        return codes[0], codes[1]

    def _predictor_codes(self, predictor: np.ndarray) -> np.ndarray:
        names, inverse = np.unique(predictor, return_inverse=True)
        for name in names.tolist():
            if name not in self.predictor_names:
                self.predictor_names.append(name)
        lookup = np.array([self.predictor_names.index(name) for name in names.tolist()],
                          np.int8)
        return lookup[inverse.reshape(-1)]

    def add(self, rows: np.ndarray, parts, summary, predictor, names) -> None:
        """One slice: its rows (k,), PartContacts, BodySummary, predictor names (k,) and the
        part-name codes (A's, B's)."""
        for key, column in self.summary.items():
            column[rows] = getattr(summary, key)
        self.predictor[rows] = self._predictor_codes(np.asarray(predictor))
        c = parts.contacts
        self.rows.append(rows[parts.pose])
        self.columns.append({
            "part_a": names[0][parts.part_a], "part_b": names[1][parts.part_b],
            "point": c.point, "normal": c.normal, "depth": c.depth,
            "contact_type": c.contact_type_code.astype(np.int8),
            "feature_a": c.feature_a.astype(np.int32),
            "feature_b": c.feature_b.astype(np.int32), "pressure": c.pressure})
        self.contacts += len(parts.pose)

    def merged(self) -> CompoundArrays:
        """The answer, part contacts in row order (rows in request order, then as found)."""
        row = np.concatenate(self.rows) if self.rows else np.zeros(0, np.int64)
        order = np.argsort(row, kind="stable")
        contacts = {}
        for name, dtype, shape in CONTACT_COLUMNS:
            parts = [c.pop(name) for c in self.columns]
            column = np.concatenate(parts) if parts else np.zeros((0, *shape), dtype)
            contacts[name] = column[order].astype(dtype, copy=False)
            del parts
        offsets = np.zeros(self.n + 1, np.int64)
        np.cumsum(np.bincount(row, minlength=self.n), out=offsets[1:])
        self.rows, self.columns = [], []
        return CompoundArrays(**self.summary, predictor=self.predictor,
                              predictor_names=np.asarray(self.predictor_names),
                              offsets=offsets, contacts=contacts,
                              part_names=np.asarray(self.part_names, dtype=str))
