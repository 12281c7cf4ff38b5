"""A frame's answer (POST /v2/frame): the pairs of bodies that touch or lie within the margin,
each in the one answer shape with the two bodies' ids.

JSON: ``{"n_bodies", "world", "mode", "model_version", "pairs": [{"a": id, "b": id, ...one
pair's answer...}]}``, A the body that comes first in the frame (a registered world's bodies
first, then the request's in order). npz: the batch's members
(:mod:`impactnet.service.codecs.answers`) with ``a`` and ``b`` (k,) ids and ``n_bodies``.
"""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import orjson

from impactnet.models.frame import FrameAnswer
from impactnet.service.codecs.answers import batch_npz, rows_json


def frame_json(frame: FrameAnswer, include, mode: str, model_version: str,
               world: str | None, notes=()) -> bytes:
    """The frame's JSON answer (module docstring); ``notes``: its warnings (a mesh replaced
    by its hull)."""
    ids_a, ids_b = frame.ids
    rows = rows_json(frame.answers, frame.pairs, include)
    pairs = [{"a": a, "b": b} | row
             for a, b, row in zip(ids_a.tolist(), ids_b.tolist(), rows, strict=True)]
    return orjson.dumps({"n_bodies": len(frame.bodies), "world": world, "mode": mode,
                         "model_version": model_version, "pairs": pairs}
                        | ({"warnings": list(notes)} if notes else {}))


def frame_npz(frame: FrameAnswer, include, mode: str, model_version: str) -> Iterator[bytes]:
    """The frame's npz answer in pieces (module docstring)."""
    ids_a, ids_b = frame.ids
    width = f"<U{max(1, max((len(i) for i in frame.bodies.ids), default=1))}"
    head = (("a", ids_a.astype(width)), ("b", ids_b.astype(width)),
            ("n_bodies", np.asarray(len(frame.bodies), np.int64)))
    return batch_npz(frame.answers, frame.pairs, include, mode, model_version, head)
