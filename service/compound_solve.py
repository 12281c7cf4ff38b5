"""Compound bodies through the HTTP API: the exact compound oracle on the rows of a request
that name a compound scene object, and its answer as JSON or npz (docs/service.md, "Compound
bodies").

Rows are grouped by their pair of bodies (object names, or raw box sizes) and each group is
one vectorised call of :func:`impactnet.models.compound.compound_answer`. The answer is the
body-level summary per row plus the ragged list of part contacts, pose-major, with
``offsets`` (n + 1,) delimiting each row's contacts.

Modes (issue #21): a pair that the bundle serves learned (``chains``) is answered in mode
``auto`` by its chain (classifier, experts, the oracle for unsure rows) and in mode
``committee`` by its chain without the oracle; ``exact`` and ``single`` (there is no single
MLP of a compound pair), and every mode for a pair recorded exact-only or without models, are
answered by the oracle. ``predictor`` names, per row, ``oracle``, ``exact-part`` or
``learned``. A request that names the bodies in the other order than the scene's pair is
answered by the oracle.
"""
from __future__ import annotations

import io

import numpy as np

from impactnet.models.compound import CompoundAnswer, compound_answer
from impactnet.models.contacts import CONTACT_TYPES
from impactnet.service.api.errors import ServiceError
from impactnet.service.predictors import PairInputs
from impactnet.service.scene import SceneView

#: The predictor named in compound answers.
ORACLE = "oracle"
#: Per-contact columns of the ragged answer (name in the answer, dtype).
CONTACT_COLUMNS = ("part_a", "part_b", "point", "normal", "depth", "contact_type",
                   "feature_a", "feature_b", "pressure")


def names_compound(pairs: PairInputs, scene: SceneView) -> bool:
    """Whether a row of ``pairs`` (parsed against ``scene.with_compound()``) names a compound
    object."""
    box_count = len(scene.object_names)
    return bool((pairs.object_a >= box_count).any() or (pairs.object_b >= box_count).any())


def _groups(pairs: PairInputs, n: int):
    """(key rows, inverse (n,)) of the distinct (object_a, object_b, size_a, size_b) rows."""
    columns = [np.broadcast_to(c, (n,) + c.shape[1:]).reshape(n, -1) for c in
               (pairs.object_a, pairs.object_b, pairs.size_a, pairs.size_b)]
    return np.unique(np.concatenate([c.astype(np.float64) for c in columns], axis=1), axis=0,
                     return_inverse=True)


def _chain_for(key, scene: SceneView, chains: dict, mode: str):
    """The chain that answers a group (its object indices in ``key``) in ``mode``, or None."""
    if mode not in ("auto", "committee") or not chains:
        return None
    names = scene.object_names + scene.compound_names
    a, b = int(key[0]), int(key[1])
    if min(a, b) < 0:
        return None
    return chains.get(f"{names[a]}/{names[b]}")


def _answer(pairs_of_group, chain, mode: str):
    """(CompoundAnswer, predictor (k,)) of one group: its chain's or the oracle's."""
    parts_a, take_a, q_a, parts_b, take_b, q_b = pairs_of_group
    if chain is None:
        answer = compound_answer(parts_a, take_a, q_a, parts_b, take_b, q_b)
        return answer, np.full(len(answer), ORACLE)
    got = chain.answer(take_a, q_a, take_b, q_b, fallback=mode == "auto")
    return (CompoundAnswer(got.parts, got.summary, tuple(p.name for p in parts_a),
                           tuple(p.name for p in parts_b)), got.predictor)


def solve_compound(pairs: PairInputs, scene: SceneView, max_per_pose: int,
                   max_per_batch: int, chains: dict | None = None,
                   mode: str = "exact") -> dict:
    """The summary columns (n rows) and the ragged part contacts of every row.

    Raises
    ------
    ServiceError
        413 ``too_many_part_contacts`` naming the cap (per pose or per batch) that is exceeded.
    """
    n = len(pairs)
    keys, inverse = _groups(pairs, n)
    inverse = inverse.reshape(-1)
    out = _empty(n)
    out["predictor"] = np.full(n, ORACLE, dtype="<U10")
    pieces, total = [], 0
    for g, key in enumerate(keys):
        rows = np.flatnonzero(inverse == g)
        parts_a = scene.parts_of(int(key[0]), key[2:5])
        parts_b = scene.parts_of(int(key[1]), key[5:8])
        take = [np.broadcast_to(c, (n,) + c.shape[1:])[rows] for c in
                (pairs.position_a, pairs.quaternion_a, pairs.position_b, pairs.quaternion_b)]
        answer, out["predictor"][rows] = _answer(
            (parts_a, take[0], take[1], parts_b, take[2], take[3]),
            _chain_for(key, scene, chains or {}, mode), mode)
        total += int(answer.parts.offsets[-1])
        pieces.append(_fill(out, answer, rows, total, max_per_pose, max_per_batch))
    return out | _ragged(pieces, n)


def _fill(out: dict, answer, rows, total: int, max_per_pose: int, max_per_batch: int) -> dict:
    """Put a group's summary into ``out`` at ``rows``; its contact columns (caps checked)."""
    _check_caps(np.diff(answer.parts.offsets), total, rows, max_per_pose, max_per_batch)
    s = answer.summary
    out["colliding"][rows], out["point"][rows], out["normal"][rows] = (s.colliding, s.point,
                                                                      s.normal)
    out["depth"][rows], out["cluster_size"][rows] = s.depth, s.cluster_size
    return _contact_columns(answer, rows)


def _empty(n: int) -> dict:
    return {"colliding": np.zeros(n, bool), "point": np.zeros((n, 3)),
            "normal": np.zeros((n, 3)), "depth": np.zeros(n),
            "cluster_size": np.zeros(n, np.int64)}


def solve_parts(parts_a, position_a, quaternion_a, parts_b, position_b, quaternion_b,
                max_per_pose: int) -> dict:
    """The answer arrays (one row) of one pair of part tuples, as :func:`solve_compound`'s."""
    answer = compound_answer(parts_a, position_a, quaternion_a, parts_b, position_b,
                             quaternion_b)
    out = _empty(1)
    rows = np.zeros(1, np.int64)
    piece = _fill(out, answer, rows, int(answer.parts.offsets[-1]), max_per_pose,
                  max_per_pose)
    return out | _ragged([piece], 1) | {"predictor": np.full(1, ORACLE)}


def _check_caps(counts, total, rows, max_per_pose, max_per_batch) -> None:
    if counts.size and counts.max() > max_per_pose:
        row = int(rows[int(np.argmax(counts))])
        raise ServiceError(413, "too_many_part_contacts",
                           f"row {row} has {int(counts.max())} part contacts, more than "
                           f"max_part_contacts_per_pose ({max_per_pose})")
    if total > max_per_batch:
        raise ServiceError(413, "too_many_part_contacts",
                           f"the batch has more than max_part_contacts_per_batch "
                           f"({max_per_batch}) part contacts; send fewer rows")


def _contact_columns(answer, rows) -> dict:
    c = answer.parts.contacts
    return {"row": rows[answer.parts.pose],
            "part_a": np.asarray(answer.names_a)[answer.parts.part_a],
            "part_b": np.asarray(answer.names_b)[answer.parts.part_b],
            "point": c.point, "normal": c.normal, "depth": c.depth,
            "contact_type": np.asarray(CONTACT_TYPES)[c.contact_type_code],
            "feature_a": c.feature_a.astype(np.int64), "feature_b": c.feature_b.astype(np.int64),
            "pressure": c.pressure}


def member(name: str) -> str:
    """The answer array (and npz member) of a per-contact column: ``contact_<name>``, and
    ``contact_type`` as itself."""
    return name if name.startswith("contact_") else f"contact_{name}"


def _ragged(pieces: list[dict], n: int) -> dict:
    """The groups' contacts merged pose-major (rows in request order, then as found)."""
    row = np.concatenate([p["row"] for p in pieces])
    order = np.argsort(row, kind="stable")
    merged = {member(name): np.concatenate([p[name] for p in pieces])[order]
              for name in CONTACT_COLUMNS}
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(row, minlength=n), out=offsets[1:])
    return merged | {"contact_offsets": offsets}


def row_json(arrays: dict, i: int) -> dict:
    """Row i as the single-pair answer's fields (summary and its ``contacts`` list)."""
    rows = range(int(arrays["contact_offsets"][i]), int(arrays["contact_offsets"][i + 1]))
    contacts = [{name: _plain(arrays[member(name)][r]) for name in CONTACT_COLUMNS}
                for r in rows]
    return {"colliding": bool(arrays["colliding"][i]), "point": arrays["point"][i].tolist(),
            "normal": arrays["normal"][i].tolist(), "depth": float(arrays["depth"][i]),
            "cluster_size": int(arrays["cluster_size"][i]),
            "predictor": str(arrays["predictor"][i]),
            "contacts": contacts}


def _plain(value):
    return value.tolist() if isinstance(value, np.ndarray | np.generic) else value


def batch_json(arrays: dict, mode: str, model_version: str) -> dict:
    """The columnar batch answer: summary columns of N and the ragged ``contacts`` object."""
    summary = ("predictor", "colliding", "point", "normal", "depth", "cluster_size")
    return {"n": len(arrays["depth"]), "mode": mode, "model_version": model_version,
            **{name: arrays[name].tolist() for name in summary},
            "contacts": {"offsets": arrays["contact_offsets"].tolist(),
                         **{name: arrays[member(name)].tolist()
                            for name in CONTACT_COLUMNS}}}


def batch_npz(arrays: dict, mode: str, model_version: str) -> bytes:
    """The batch answer as an npz archive: the same columns, contacts as ``contact_*``."""
    buffer = io.BytesIO()
    members = {name: np.asarray(value) for name, value in arrays.items()}
    members["predictor"] = members["predictor"].astype("<U10")
    for name in ("contact_part_a", "contact_part_b", "contact_type"):
        members[name] = members[name].astype(str)
    np.savez(buffer, mode=np.asarray(mode), model_version=np.asarray(model_version), **members)
    return buffer.getvalue()
