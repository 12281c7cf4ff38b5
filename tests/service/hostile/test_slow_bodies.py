"""Issue 23, item 1: slow bodies must not hold the compute slots, and must end.

Reproducer: 64 sockets each send the headers and one byte of a ``Content-Length: 1000`` body,
then stall. Before the fix every /v1 request then got 503 ``overloaded`` for as long as the
sockets stayed open, /readyz stayed 200, and a shutdown waited ``graceful_timeout_s`` for
them.
"""
from __future__ import annotations

import asyncio
import threading
import time

import httpx
import orjson
import pytest

from impactnet.service.app import create_app
from impactnet.service.limits.saturation import GAP_S
from tests.service.conftest import PAIR, get, test_settings
from tests.service.hostile.conftest import post, read_reply, stalled_sockets
from tests.service.test_limits import SMALL_BATCH, hold_a_slot

#: Stalled uploads in the reproducer: more than the 64 compute slots.
STALLED = 80
#: Body deadline of the test servers (s): short, so that the test sees it expire.
BODY_TIMEOUT_S = 3.0
#: What a normal client's request may take while the sockets stall (s, issue 23).
NORMAL_LATENCY_S = 1.0


@pytest.mark.slow
def test_stalled_uploads_hold_no_slot_and_get_408(server_factory):
    proc = server_factory("--body-timeout", str(BODY_TIMEOUT_S))
    sockets = stalled_sockets(proc.port, STALLED)
    try:
        started = time.monotonic()
        pair = orjson.dumps(PAIR)
        while time.monotonic() - started < BODY_TIMEOUT_S - 1.0:  # all the while they stall
            sent = time.monotonic()
            status, _, body = post(proc.port, "/v2/contact", pair)
            assert status == 200, body
            assert time.monotonic() - sent < NORMAL_LATENCY_S
        assert get(proc.port, "/readyz")[0] == 200  # nothing was refused: not saturated
        replies = [read_reply(s, BODY_TIMEOUT_S + 5) for s in sockets]
        assert time.monotonic() - started < BODY_TIMEOUT_S + 5
    finally:
        for sock in sockets:
            sock.close()
    assert all(r.startswith(b"HTTP/1.1 408") and b"body_timeout" in r for r in replies), \
        {r[:40] for r in replies}
    status, text = get(proc.port, "/metrics")
    assert status == 200 and f'reason="body_timeout"}} {STALLED}.0'.encode() in text


@pytest.mark.slow
def test_a_stalled_upload_does_not_hold_the_shutdown(server_factory):
    proc = server_factory("--body-timeout", "60", "--graceful-timeout", "30",
                          "--drain-delay", "0.2")
    sockets = stalled_sockets(proc.port, 2)
    try:
        time.sleep(0.2)  # the server is reading them
        stopped = time.monotonic()
        proc.terminate()
        assert proc.proc.wait(10) == 0
        assert time.monotonic() - stopped < 5  # not graceful_timeout_s (30 s)
        replies = [read_reply(s, 5) for s in sockets]
    finally:
        for sock in sockets:
            sock.close()
    assert all(r.startswith(b"HTTP/1.1 503") and b"shutting down" in r for r in replies)


def test_saturation_that_persists_turns_readyz_503_until_it_ends():
    """Refusals for longer than ``saturation_ready_s`` make /readyz say 503 ``saturated``; a
    pause of ``GAP_S`` without a refusal makes it 200 again (in process, deterministic)."""
    async def main():
        app = create_app(test_settings(max_concurrency=1, saturation_ready_s=0.3))
        await app.state.runtime.load()
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            gate, held = await hold_a_slot(app, client)
            before = await client.get("/readyz")
            refused, until = [], time.monotonic() + 0.6
            while time.monotonic() < until:
                refused.append((await client.post("/v2/contact", json=PAIR)).status_code)
                await asyncio.sleep(0.05)
            during = await client.get("/readyz")
            gate.release.set()
            assert (await held).status_code == 200
            await asyncio.sleep(GAP_S + 0.2)
            after = await client.get("/readyz")
        return before, set(refused), during, after

    before, refused, during, after = asyncio.run(main())
    assert before.status_code == 200
    assert refused == {503}
    assert during.status_code == 503 and during.json()["reason"].startswith("saturated")
    assert during.headers["retry-after"] == "1"
    assert after.status_code == 200


def test_the_compute_slot_is_free_while_the_answer_is_sent():
    """A slot counts computing only: a batch whose answer is being sent (a large one is
    streamed) holds none."""
    async def main():
        app = create_app(test_settings(max_concurrency=1))
        await app.state.runtime.load()
        started, release = threading.Event(), asyncio.Event()
        seen = []

        async def send(message):
            if message["type"] == "http.response.start":
                started.set()
                await release.wait()  # a client that does not read its answer yet

        scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1",
                 "method": "POST", "path": "/v2/contact/batch",
                 "raw_path": b"/v2/contact/batch",
                 "query_string": b"", "root_path": "", "scheme": "http",
                 "server": ("127.0.0.1", 8000), "client": ("127.0.0.1", 5000),
                 "headers": [(b"content-type", b"application/json")]}
        body = orjson.dumps(SMALL_BATCH)
        messages = [{"type": "http.request", "body": body, "more_body": False}]

        async def receive():
            return messages.pop() if messages else await asyncio.sleep(3600)

        slow = asyncio.create_task(app(dict(scope), receive, send))
        await asyncio.to_thread(started.wait, 10)
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            seen.append((await client.post("/v2/contact", json=PAIR)).status_code)
        release.set()
        await slow
        return seen

    assert asyncio.run(main()) == [200]
