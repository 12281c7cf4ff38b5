"""A batch's body decoded, in two steps that each run in the lane their known cost chooses
(:mod:`impactnet.service.limits.lanes`):

1. :func:`parse`: the body (npz or JSON) into columns and options; cost ~ the body's bytes;
2. :func:`validate`: the columns validated into the dispatcher's pairs; cost ~ the rows.

Every step reserves its memory in the request's lease before it allocates; the pairs are then
solved by :mod:`impactnet.service.solve`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from impactnet.service.codecs import columns as col
from impactnet.service.codecs.batch_json import parse_json_batch
from impactnet.service.codecs.npz import parse_npz
from impactnet.service.codecs.requests import BatchOptions
from impactnet.service.errors import InputError, validation_items
from impactnet.service.limits.budget import Lease

#: Bytes of a request body that parse in about the time of one box-pair solve (~1 us): the
#: parse step's cost in the lanes' unit.
PARSE_BYTES_PER_UNIT = 64
#: Upper bound of the validated inputs per pair, bytes (shape indices, positions and
#: quaternions of both bodies in float64, the float64 copies of integer columns and the
#: rotation conversion's temporaries): tracemalloc peaks of 100,000-pair batches were 80
#: (quaternions), 400 (int8 Euler angles) and 456 (matrices and names).
PAIR_INPUT_BYTES = 512


@dataclass
class Parsed:
    """A batch's body decoded (step 1)."""

    columns: dict  # column name -> array
    options: BatchOptions
    rows: int  # pairs the columns hold


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


def validate(parsed: Parsed, scene, settings, lease: Lease):
    """Step 2: the dispatcher's pairs of the columns, their memory reserved first."""
    lease.reserve(min(parsed.rows, settings.max_batch_pairs) * PAIR_INPUT_BYTES,
                  "validating the batch")
    pairs = col.batch_pairs(parsed.columns, scene, parsed.options.euler_convention,
                            settings.max_batch_pairs)
    parsed.columns = {}
    return pairs
