"""The steps of a batch request, each run in the lane its known cost chooses
(:mod:`impactnet.service.limits.lanes`):

1. :func:`parse`: the body (npz or JSON) into columns and options; cost ~ the body's bytes;
2. :func:`validate`: the columns validated into pairs (cost ~ rows), and for compound rows
   :func:`count`: the broadphase's count and the memory reservation
   (:mod:`impactnet.service.compound_solve`; cost ~ rows x the bodies' part pairs);
3. :func:`solve`: the pairs' answers; cost = the admitted work (box rows, or compound
   candidates weighted by their hulls); large answers are encoded as a stream afterwards.

Every step reserves its memory in the request's lease before it allocates, and the solvers
stop at their next chunk when the request's deadline passes or its client leaves.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from impactnet.service import compound_solve as cs
from impactnet.service.api.schemas import BatchOptions
from impactnet.service.batch_solve import PAIR_INPUT_BYTES, solve_batch
from impactnet.service.codecs import columns as col
from impactnet.service.codecs import compound_encode
from impactnet.service.codecs.answer_encode import STREAM_ROWS, encode_json, encode_npz
from impactnet.service.codecs.batch_json import parse_json_batch
from impactnet.service.codecs.npz import parse_npz
from impactnet.service.errors import InputError, validation_items
from impactnet.service.limits.budget import Lease
from impactnet.service.predictors import PairInputs, ServingState

#: Bytes of a request body that parse in about the time of one box-pair solve (~1 us): the
#: parse step's cost in the lanes' unit.
PARSE_BYTES_PER_UNIT = 64
#: Compound answers of up to this many part contacts are encoded at once; larger ones stream.
COMPOUND_STREAM_CONTACTS = 16_384


@dataclass
class Parsed:
    """A batch's body decoded (step 1)."""

    columns: dict  # column name -> array
    options: BatchOptions
    rows: int  # pairs the columns hold


@dataclass
class Admitted:
    """A batch's validated pairs, and for compound rows their admitted plan (step 2)."""

    pairs: PairInputs
    mode: str
    include: list
    plan: cs.Plan | None  # None: box pairs only
    work: float  # the solve's cost in box-pair solves


def parse_cost(body: bytes) -> float:
    return len(body) / PARSE_BYTES_PER_UNIT


def _options(query: dict, body: dict) -> BatchOptions:
    both = sorted(k for k in body if query.get(k) not in (None, []))
    if both:
        raise InputError(both[0], "given both in the query string and in the body")
    merged = {**{k: v for k, v in query.items() if v not in (None, [])}, **body}
    try:
        return BatchOptions.model_validate(merged)
    except ValidationError as exc:
        first = validation_items(exc.errors())[0]
        raise InputError(first["field"], first["reason"], type_=first["type"]) from exc


def _rows(columns: dict) -> int:
    """Pairs of a batch: the longest per-pair column (1 if every column is one value)."""
    rows = 1
    for name, value in columns.items():
        if name not in col.COLUMNS or not isinstance(value, np.ndarray):
            continue  # refused by the validation that follows
        tail = col.tail_of(name) or ()
        if value.ndim == len(tail) + 1:
            rows = max(rows, len(value))
    return rows


def parse(body: bytes, binary: bool, query: dict, settings, lease: Lease) -> Parsed:
    """Step 1: the columns and options of a batch body."""
    if binary:
        columns, body_options = parse_npz(body, settings.max_body_bytes,
                                          settings.max_batch_pairs, lease), {}
    else:
        columns, body_options = parse_json_batch(body, settings.max_batch_pairs, lease)
    return Parsed(columns, _options(query, body_options), _rows(columns))


def validate(parsed: Parsed, state: ServingState, settings, lease: Lease) -> Admitted:
    """Step 2: validated pairs; compound rows grouped (their count is :func:`count`'s)."""
    options = parsed.options
    mode = options.mode or state.default_mode
    lease.reserve(min(parsed.rows, settings.max_batch_pairs) * PAIR_INPUT_BYTES,
                  "validating the batch")
    pairs = col.batch_pairs(parsed.columns, state.scene.with_compound,
                            options.euler_convention, settings.max_batch_pairs)
    parsed.columns = {}
    if not cs.names_compound(pairs, state.scene):
        return Admitted(pairs, mode, options.include, None, float(len(pairs)))
    groups = cs.groups_of_pairs(pairs, state.scene, state.compound, mode)
    return Admitted(pairs, mode, options.include, cs.Plan(len(pairs), groups, 0.0),
                    cs.count_cost(groups))


def count(admitted: Admitted, settings, lease: Lease) -> Admitted:
    """Step 2b (compound rows): the broadphase's count under the caps, the memory reserved."""
    plan = cs.admit(admitted.plan.groups, admitted.plan.n, cs.CompoundCaps.of(settings), lease)
    admitted.plan, admitted.work = plan, plan.work
    return admitted


def solve(admitted: Admitted, state: ServingState, runtime, answer_type: str, lease: Lease):
    """Step 3: the answer as bytes (small) or as something to stream: ``(kind, payload)``
    with kind ``bytes``, ``box_json`` (arrays), ``compound_json`` or ``compound_npz``."""
    mode, settings = admitted.mode, runtime.settings
    if admitted.plan is not None:
        arrays = cs.solve(admitted.plan, cs.CompoundCaps.of(settings), mode)
        counts = np.bincount(arrays.predictor, minlength=len(arrays.predictor_names))
        runtime.metrics.record_predictions(mode, dict(zip(arrays.predictor_names.tolist(),
                                                          counts.tolist(), strict=True)))
        kind = "compound_npz" if answer_type == col.NPZ else "compound_json"
        if len(arrays.contacts["depth"]) > COMPOUND_STREAM_CONTACTS:
            return kind, arrays
        encode = (compound_encode.encode_npz if kind == "compound_npz"
                  else compound_encode.encode_json)
        return "bytes", encode(arrays, mode, state.model_version)
    arrays = solve_batch(state.predictor(mode), admitted.pairs, admitted.include, lease)
    counts = np.bincount(arrays["predictor_code"], minlength=len(arrays["predictor_names"]))
    runtime.metrics.record_predictions(mode, dict(zip(arrays["predictor_names"].tolist(),
                                                      counts.tolist(), strict=True)))
    runtime.metrics.batch_size.observe(len(admitted.pairs))
    if answer_type == col.NPZ:
        lease.reserve(2 * sum(a.nbytes for a in arrays.values()), "encoding the npz answer")
        return "bytes", encode_npz(arrays, mode, state.model_version)
    if len(admitted.pairs) <= STREAM_ROWS:
        return "bytes", encode_json(arrays, mode, state.model_version)
    return "box_json", arrays
