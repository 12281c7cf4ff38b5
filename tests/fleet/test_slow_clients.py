"""Slow clients at the front: the stalled-upload reproducer of issue 23
(tests/service/hostile/test_slow_bodies.py) rerun through nginx.

80 sockets each send the headers and one byte of a 1000-byte body, then stall. The front
buffers bodies (``proxy_request_buffering on``), so they stay at nginx and never reach a
replica; a normal client keeps getting answers at once, a 100,000-pair npz batch (16 MB, through
the front's temp file) passes, and ``client_body_timeout`` (10 s between two reads) closes the
stalled connections.
"""
from __future__ import annotations

import re
import time

import orjson
import pytest

from impactnet.service.fleet import nginx_conf
from impactnet.service.fleet.local import Fleet, status_of
from tests.fleet.helpers import PAIR, npz_batch
from tests.service.conftest import get
from tests.service.hostile.conftest import post, read_reply, stalled_sockets
from tests.service.hostile.test_slow_bodies import NORMAL_LATENCY_S, STALLED

#: The front's client_body_timeout in seconds, read from the shipped template.
BODY_TIMEOUT_S = float(re.search(r"client_body_timeout (\d+)s;",
                                 nginx_conf.TEMPLATE.read_text()).group(1))
#: Pairs of the large batch sent while the uploads stall: the service's largest batch.
LARGE_BATCH = 100_000


@pytest.mark.slow
def test_stalled_uploads_stay_at_the_front_and_normal_clients_are_answered(nginx):
    with Fleet(3, ["--bundle", "none", "--no-access-log"], nginx=nginx) as fleet:
        port = fleet.front.port
        sockets = stalled_sockets(port, STALLED)
        try:
            started = time.monotonic()
            status, _, body = post(port, "/v2/contact/batch", npz_batch(LARGE_BATCH),
                                   {"Content-Type": "application/x-npz"})
            assert status == 200, body[:300]
            replicas, pair = set(), orjson.dumps(PAIR)
            while time.monotonic() - started < BODY_TIMEOUT_S - 2.0:  # while they stall
                sent = time.monotonic()
                status, headers, body = post(port, "/v2/contact", pair)
                assert status == 200, body
                assert time.monotonic() - sent < NORMAL_LATENCY_S
                replicas.add(headers["x-replica"])
            assert replicas == {"r1", "r2", "r3"}
            assert all(status_of(m.port) == 200 for m in fleet.members)  # none saturated
            replies = [read_reply(s, BODY_TIMEOUT_S + 5) for s in sockets]
            closed_after = time.monotonic() - started
        finally:
            for sock in sockets:
                sock.close()
        # nginx ends a body timeout by closing the connection (408 in its log, no answer)
        assert all(r == b"" or r.startswith(b"HTTP/1.1 408") for r in replies), \
            {r[:40] for r in replies}
        assert closed_after < BODY_TIMEOUT_S + 5
        # no replica ever saw one of the stalled uploads
        for member in fleet.members:
            status, text = get(member.port, "/metrics")
            timeouts = re.findall(rb'reason="body_timeout"} ([0-9.e+]+)', text)
            assert status == 200 and all(float(n) == 0 for n in timeouts)

