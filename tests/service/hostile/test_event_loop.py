"""Issue 23, item 3: bodies that stalled the event loop are refused, cheaply and with small errors.

Reproducers: a 38 MB ``/v2/contact`` body of 3 million unknown keys took 35 s and froze
/healthz for 35 s; its error listed every key (300,000 keys made a 3.5 MB request into a 31 MB
answer). Now a single pair's body is capped at 64 KiB (413 from Content-Length, or as soon as a
chunked body passes the cap), a body within the cap is parsed off the event loop when it is
large, an error lists at most 20 problems and counts the rest, and a JSON batch of millions of
keys is refused from its counts, unparsed.
"""
from __future__ import annotations

import itertools
import socket
import time

import orjson
import pytest

from impactnet.service.errors import MAX_DETAIL_ITEMS
from tests.service.conftest import PAIR, assert_error
from tests.service.hostile.conftest import HEALTHZ_P99_MS, HealthSampler, post, read_reply

PAIR_BODY_CAP = 64 * 1024
#: Seconds the hostile bodies are sent for while /healthz is probed.
HOSTILE_SECONDS = 4.0
#: Unknown keys of the hostile batch body (3 MB): more strings than 100,000 pairs can hold.
BATCH_KEYS = 250_000


def _unknown_keys(count: int) -> bytes:
    """A valid pair with ``count`` unknown keys in ``a``."""
    extra = b"".join(b',"k%d":0' % i for i in range(count))
    return (b'{"a":{"size":[2,2,2],"position":[0,0,0],"quaternion":[1,0,0,0]' + extra
            + b'},"b":{"size":[2,2,2],"position":[0,0,1.9],"quaternion":[1,0,0,0]}}')


def pair_with_names(a: str, b: str) -> dict:
    return {"a": {"object": a, "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
            "b": {"object": b, "position": [0, 0, 1.9], "quaternion": [1, 0, 0, 0]}}


def _declared(port: int, path: str, declared: int, first: bytes) -> bytes:
    """Headers declaring a ``declared``-byte body and its first bytes; the reply."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(b"POST %s HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                     b"Content-Length: %d\r\n\r\n%s" % (path.encode(), declared, first))
        return read_reply(sock, 10)


def _chunked(port: int, body: bytes, chunk: int = 16384) -> bytes:
    """``body`` sent chunked (no Content-Length) until the server answers; the reply."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(b"POST /v2/contact HTTP/1.1\r\nHost: x\r\nContent-Type: application/json"
                     b"\r\nTransfer-Encoding: chunked\r\n\r\n")
        try:
            for i in range(0, len(body), chunk):
                piece = body[i:i + chunk]
                sock.sendall(b"%x\r\n%s\r\n" % (len(piece), piece))
            sock.sendall(b"0\r\n\r\n")
        except OSError:  # the server answered and closed before the end: as it should
            pass
        return read_reply(sock, 10)


def test_error_details_are_capped(client):
    """44 bad numbers (every coordinate of both bodies a string): 20 listed, one counts."""
    bad = {"object": "cube", "size": ["x"] * 3, "position": ["x"] * 3,
           "quaternion": ["x"] * 4, "matrix": [["x"] * 3] * 3, "euler": ["x"] * 3}
    response = client.post("/v2/contact", json={"a": bad, "b": bad})
    answer = assert_error(response, 422, "a.size", "invalid_input")
    assert len(answer["detail"]) == MAX_DETAIL_ITEMS + 1
    assert answer["detail"][-1]["type"] == "too_many_errors"
    assert answer["detail"][-1]["reason"].endswith("more problems not listed")


def test_unknown_keys_are_refused_unparsed(client):
    """5,000 unknown keys (a 60 KB body): 422 from the count of keys, a small answer."""
    body = _unknown_keys(5000)
    assert len(body) < PAIR_BODY_CAP
    response = client.post("/v2/contact", content=body,
                           headers={"Content-Type": "application/json"})
    answer = assert_error(response, 422, "body", "invalid_input")
    assert answer["detail"][0]["type"] == "too_many_keys" and len(response.content) < 1024
    with_colons = pair_with_names("a:b", "c:d")  # colons inside strings are not keys
    assert client.post("/v2/contact", json=with_colons).status_code == 422  # unknown names
    assert_error(client.post("/v2/contact", json=with_colons), 422, "a.object")


def test_a_pair_body_above_64_kib_is_413(client):
    response = client.post("/v2/contact", content=_unknown_keys(8000),
                           headers={"Content-Type": "application/json"})
    assert_error(response, 413, None, "body_too_large")
    assert client.post("/v2/contact", json=PAIR).status_code == 200


@pytest.mark.slow
def test_healthz_keeps_answering_while_hostile_bodies_are_refused(server_factory):
    proc = server_factory()
    keys_38mb = _unknown_keys(3_000_000)
    # more keys (strings) than a batch of 100,000 pairs can hold: refused from the count
    batch_keys = b"{" + b",".join(b'"k%d":0' % i for i in range(BATCH_KEYS)) + b"}"
    deep = b'{"a":' + b"[" * 30_000 + b"]" * 30_000 + b"}"
    within_cap = _unknown_keys(5000)
    hostile = itertools.cycle([
        lambda: _declared(proc.port, "/v2/contact", len(keys_38mb), keys_38mb[:65536]),
        lambda: _chunked(proc.port, keys_38mb[:1 << 20]),
        lambda: post(proc.port, "/v2/contact", within_cap),
        lambda: post(proc.port, "/v2/contact", deep),
        lambda: post(proc.port, "/v2/contact/batch", batch_keys),
    ])
    outcomes = []
    with HealthSampler(proc.port) as health:
        until = time.monotonic() + HOSTILE_SECONDS
        while time.monotonic() < until:
            started = time.monotonic()
            reply = next(hostile)()
            outcomes.append((reply, time.monotonic() - started))
    for reply, seconds in outcomes:
        if isinstance(reply, bytes):  # raw socket: the 413 of the pair cap
            assert reply.startswith(b"HTTP/1.1 413") and b"body_too_large" in reply, reply[:80]
        else:
            status, _, body = reply
            assert status in (413, 422), body[:200]
            assert len(body) < 8192  # small, whatever the request
            assert len(orjson.loads(body)["detail"]) <= MAX_DETAIL_ITEMS + 1
        assert seconds < 2.0
    assert len(outcomes) >= 10
    print(f"\nhostile bodies: {len(outcomes)} refused in {HOSTILE_SECONDS:.0f} s; /healthz p99 "
          f"{health.p99():.1f} ms, max {max(health.ms):.1f} ms over {len(health.ms)} probes")
    assert health.p99() <= HEALTHZ_P99_MS
