"""The requests of `impactnet bench hostile`: each reproducer of the hostile probe of the compound
paths, as bytes, with what a server must answer, and the goals a replica must keep under them
(issue #31; :mod:`impactnet.training.bench.http.hostile` measures them, ``hostile_report`` writes
them up). Loopback only, bounded sizes."""
from __future__ import annotations

import io
import json
from dataclasses import dataclass

import numpy as np

MiB = 1 << 20
#: Goals of issue #31: /healthz p99 under attack, a 10-pair batch beside two large ones, idle
#: memory within ready + a slack 10 s after the last request, and a replica's memory.
HEALTHZ_P99_GOAL_MS = 50.0
SMALL_BATCH_GOAL_S = 0.5
IDLE_SLACK_BYTES = 64 * MiB
REPLICA_BYTES = 1 << 30

#: A pose with no rotation.
LEVEL = [1.0, 0.0, 0.0, 0.0]
#: Positions of B over A: two 40 ft containers pushed 5 cm into each other side by side (every
#: part pair near another), stacked castings on castings, 50 m apart, and within reach (each
#: small box's sphere meets the container's).
OVERLAP, STACKED, FAR, NEAR = [0.05, 0.0, 0.0], [0.0, 0.0, 2.589], [50.0, 0.0, 0.0], \
    [0.0, 0.0, 1.5]


@dataclass(frozen=True)
class Attack:
    """One hostile request: where it goes, its body, and the answers that are right."""

    name: str  # row of the report
    what: str  # the reproducer, in words
    path: str  # /v2/contact or /v2/contact/batch
    body: bytes
    npz: bool  # body (and answer) as npz
    expect: tuple[int, ...]  # statuses a bounded server may answer
    parallel: int = 1  # sent this many times at once


def npz_body(**columns) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    return buffer.getvalue()


def _pair(a: dict, b: dict) -> bytes:
    return json.dumps({"a": a, "b": b}).encode()


def _inline(*parts: dict, position=(0.0, 0.0, 0.0)) -> dict:
    return {"parts": list(parts), "position": list(position), "quaternion": LEVEL}


def _frustum(name: str, sides: int) -> dict:
    return {"name": name, "frustum": {"sides": sides, "base": 0.5, "height": 0.3}}


def _box(z: float) -> dict:
    return {"size": [1.0, 1.0, 1.0], "position": [0.0, 0.0, z], "quaternion": LEVEL}


def _containers(rows: int, position, json_body: bool = False) -> bytes:
    """``rows`` poses of container40 on container40 at ``position``, as a 1-2 KB npz (int8
    angles, broadcast bodies) or as JSON."""
    if json_body:
        return json.dumps({"a_object": "container40", "b_object": "container40",
                           "a_position": [0, 0, 0], "b_position": [list(position)] * rows,
                           "a_quaternion": LEVEL, "b_quaternion": LEVEL}).encode()
    return npz_body(a_object=np.array("container40"), b_object=np.array("container40"),
                    a_position=np.zeros(3), b_position=np.array(position),
                    a_euler=np.zeros(3), b_euler=np.zeros((rows, 3), np.int8))


def attacks(quick: bool = False) -> list[Attack]:
    """The reproducers (fewer rows with ``quick``)."""
    scale = 10 if quick else 1
    points = np.random.default_rng(0).normal(size=(1024, 3)).round(6).tolist()
    far_sizes = np.random.default_rng(1).uniform(0.5, 2.0, (100_000 // scale, 3))
    return [
        Attack("mesh_path", "inline mesh naming a server file", "/v2/contact",
               _pair(_inline({"name": "m", "mesh": "/etc/passwd"}), _box(0.79)), False, (422,)),
        Attack("frustum_5000", "a 5,000-sided frustum (220 bytes)", "/v2/contact",
               _pair(_inline(_frustum("f", 5000)), _box(0.79)), False, (413,)),
        Attack("frustums_at_limit", "two frustums of the most sides allowed (256)",
               "/v2/contact", _pair(_inline(_frustum("f", 256)),
                                    _inline(_frustum("g", 256), position=(0, 0, 0.2))),
               False, (200,)),
        Attack("hull_at_limit", "a hull of the most points allowed (1,024)", "/v2/contact",
               _pair(_inline({"name": "h", "points": points}), _box(2.0)), False, (200,)),
        Attack("overlap_8400", "8,400 overlapping container pairs (1.3 KB npz)",
               "/v2/contact/batch", _containers(8_400 // scale, OVERLAP), True, (200, 413)),
        Attack("stacked_100k", "100,000 stacked container pairs (1.3 KB npz)",
               "/v2/contact/batch", _containers(100_000 // scale, STACKED), True, (200, 413)),
        Attack("overlap_16x1000", "sixteen 1,000-row overlap batches at once",
               "/v2/contact/batch", _containers(1_000 // scale, OVERLAP), True, (200, 503),
               parallel=16),
        Attack("stacked_json_20k", "20,000 stacked rows answered as JSON (streamed)",
               "/v2/contact/batch", _containers(20_000 // scale, STACKED, True), False, (200,)),
        Attack("distinct_far_100k", "100,000 distinct box sizes 50 m from a container",
               "/v2/contact/batch", npz_body(a_size=far_sizes, b_object=np.array("container40"),
                                             a_position=np.zeros(3), b_position=np.array(FAR),
                                             a_euler=np.zeros(3), b_euler=np.zeros(3)),
               True, (200,)),
        Attack("distinct_near_100k", "100,000 distinct box sizes beside a container",
               "/v2/contact/batch", npz_body(a_size=far_sizes, b_object=np.array("container40"),
                                             a_position=np.zeros(3), b_position=np.array(NEAR),
                                             a_euler=np.zeros(3), b_euler=np.zeros(3)),
               True, (413,)),
    ]


def small_batch() -> bytes:
    """The 10-pair box batch that must not wait behind large ones (JSON)."""
    return json.dumps({"a_size": [1, 1, 1], "b_size": [1, 1, 1], "a_position": [0, 0, 0],
                       "b_position": [[0, 0, 0.99]] * 10, "a_quaternion": LEVEL,
                       "b_quaternion": LEVEL}).encode()


def large_batch(rows: int = 1_000) -> bytes:
    """A large compound batch (~5-15 s of work): overlapping containers."""
    return _containers(rows, OVERLAP)
