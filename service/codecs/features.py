"""Features named for every part, vectorised: a box part's by the box's fixed ids (``face +z``,
``edge x(+y,-z)``, ``vertex (+,-,+)``), a convex part's by its hull's ids (``face 3``,
``edge 17``, ``vertex 40``; faces first, then edges, then vertices), ``none`` for -1.

An answer's feature is ``{id, name, kind}`` everywhere: one object in a single pair's answer,
one column per key in a batch's (``{"id": [...], "name": [...], "kind": [...]}``), with the
part named beside it at the body level (``part``).
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.body_table import body_table
from impactnet.models.compound.parts import BoxPart
from impactnet.models.dispatch import Answers
from impactnet.models.geometry import box_features as bf

#: Box feature names and kinds by id + 1 (id -1: none).
_BOX_NAMES = np.array([bf.feature_name(i) for i in range(-1, bf.N_FEATURES)])
_BOX_KINDS = np.array([str(bf.feature_kind(i)) for i in range(-1, bf.N_FEATURES)])


def _part_tables(answers: Answers) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per part code: is a box part, its hull's face count, its edge count."""
    n = len(answers.part_names)
    is_box, faces, edges = np.zeros(n, bool), np.zeros(n, np.int64), np.zeros(n, np.int64)
    for code, (shape, index) in enumerate(zip(answers.shapes, answers.part_index.tolist())):
        part = shape.parts[index]
        if isinstance(part, BoxPart):
            is_box[code] = True
            continue
        hull = body_table(shape.parts).hulls[index]
        faces[code], edges[code] = hull.n_faces, hull.n_edges
    return is_box, faces, edges


def labels(answers: Answers, parts: np.ndarray, ids: np.ndarray,
           tables=None) -> tuple[np.ndarray, np.ndarray]:
    """(names (k,), kinds (k,)) of features ``ids`` (k,) of part codes ``parts`` (k,); a part
    code of -1 or an id of -1 is ``none``. ``tables``: :func:`tables_of` (computed if None)."""
    is_box, faces, edges = tables if tables is not None else tables_of(answers)
    parts, ids = np.asarray(parts, np.int64), np.asarray(ids, np.int64)
    names = np.full(len(ids), "none", dtype=object)
    kinds = np.full(len(ids), "none", dtype=object)
    known = (parts >= 0) & (ids >= 0)
    box = known.copy()  # an answer without any part code has empty tables
    box[known] = is_box[parts[known]]
    names[box], kinds[box] = _BOX_NAMES[ids[box] + 1], _BOX_KINDS[ids[box] + 1]
    hull = known & ~box
    if hull.any():
        f, e = faces[parts[hull]], edges[parts[hull]]
        local = ids[hull]
        kind = np.where(local < f, "face", np.where(local < f + e, "edge", "vertex"))
        index = np.where(local < f, local, np.where(local < f + e, local - f, local - f - e))
        names[hull] = np.char.add(np.char.add(kind.astype(str), " "), index.astype(str))
        kinds[hull] = kind
    return names, kinds


def tables_of(answers: Answers):
    """The per-part tables :func:`labels` reads (build once per answer)."""
    return _part_tables(answers)


def feature(answers: Answers, part: int, feature_id: int, tables=None) -> dict:
    """One feature as ``{id, name, kind}``."""
    names, kinds = labels(answers, np.array([part]), np.array([feature_id]), tables)
    return {"id": int(feature_id), "name": str(names[0]), "kind": str(kinds[0])}
