"""Issue #31, items 4, 6, 11 and 12: every request has a compute deadline, work stops when its
client leaves, small work is never queued behind large work, an oversized body's 413 reaches a
client that sends it whole.

Mechanisms, not timings: the slices solved after the deadline or the disconnect are counted;
the small batch is answered while the large lane's threads are held on purpose.
"""
from __future__ import annotations

import asyncio
import http.client
import io
import json
import threading
import time

import numpy as np
import pytest

from impactnet.models.compound import candidates as candidates_module
from impactnet.models.dispatch import plan as dispatch_plan
from impactnet.models.dispatch import solve as dispatch_solve
from impactnet.service import solve as service_solve
from impactnet.service.app import create_app
from tests.service.conftest import assert_error, test_settings
from tests.service.hostile.conftest import cpu_seconds, memory_kib

NPZ = {"Content-Type": "application/x-npz", "Accept": "application/x-npz"}
STACKED = [0.0, 0.0, 2.589]


def _containers(rows: int, position=STACKED) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, a_object=np.array("container40"), b_object=np.array("container40"),
             a_position=np.zeros(3), b_position=np.array(position, float),
             a_euler=np.zeros(3), b_euler=np.zeros((rows, 3), np.int8))
    return buffer.getvalue()


@pytest.fixture
def slow_slices(monkeypatch):
    """Every slice of the narrowphase takes at least 50 ms more; the slices solved, kept."""
    calls = []
    answer = candidates_module.answer_of_poses

    def slow(*args):
        time.sleep(0.05)
        calls.append(time.monotonic())
        return answer(*args)

    monkeypatch.setattr(dispatch_solve, "answer_of_poses", slow)  # where the dispatcher finds it
    monkeypatch.setattr(dispatch_plan, "SLICE_CANDIDATES", 400)  # 10 stacked poses a slice
    return calls


def test_work_past_its_deadline_stops_and_answers_504(make_client, slow_slices):
    client = make_client(scene="quay_crane_detail", compute_deadline_s=0.3)
    started = time.monotonic()
    response = client.post("/v2/contact/batch", content=_containers(400), headers=NPZ)
    answer = assert_error(response, 504, error="deadline_exceeded")
    assert answer["limit"] == "compute_deadline_s"
    assert 3 <= len(slow_slices) < 40  # stopped after ~6 of its 40 slices
    assert all(t < started + 0.3 + 0.2 for t in slow_slices)  # none long after the deadline
    assert "impactnet_deadline_exceeded_total 1.0" in client.get("/metrics").text


async def _run_and_disconnect(app, body: bytes, leave_after_s: float) -> list[dict]:
    """Drive the ASGI app: the body arrives, then the client leaves after ``leave_after_s``."""
    sent, first = [], True

    async def receive():
        nonlocal first
        if first:
            first = False
            return {"type": "http.request", "body": body, "more_body": False}
        await asyncio.sleep(leave_after_s)
        return {"type": "http.disconnect"}

    async def send(message):
        sent.append(message)

    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1",
             "method": "POST", "path": "/v2/contact/batch", "raw_path": b"/v2/contact/batch",
             "query_string": b"", "root_path": "", "scheme": "http",
             "server": ("127.0.0.1", 8000), "client": ("127.0.0.1", 5000),
             "headers": [(b"content-type", b"application/x-npz"),
                         (b"content-length", str(len(body)).encode())]}
    await app.state.runtime.load()
    await asyncio.wait_for(app(scope, receive, send), timeout=30)
    return sent


def test_work_stops_when_its_client_disconnects(slow_slices):
    app = create_app(test_settings(scene="quay_crane_detail"))
    asyncio.run(_run_and_disconnect(app, _containers(400), 0.3))
    assert len(slow_slices) < 15  # 40 slices of 50 ms: stopped at ~6
    text = app.state.runtime.metrics.registry
    from prometheus_client import generate_latest

    assert b'impactnet_cancelled_work_total{reason="client_disconnected"} 1.0' in \
        generate_latest(text)


def test_a_small_batch_is_answered_while_the_large_lane_is_held(make_client, monkeypatch):
    client = make_client(scene="quay_crane_detail")
    held, release = threading.Semaphore(0), threading.Event()
    solve = service_solve._solve

    def holding(dispatcher, plan, caps):  # the solve step, in its lane's thread
        if plan.work > client.app.state.runtime.settings.small_work_max:
            held.release()
            release.wait(30)
        return solve(dispatcher, plan, caps)

    monkeypatch.setattr(service_solve, "_solve", holding)
    large = [threading.Thread(target=client.post, args=("/v2/contact/batch",),
                              kwargs={"content": _containers(2_000), "headers": NPZ})
             for _ in range(2)]
    for thread in large:
        thread.start()
    try:
        assert held.acquire(timeout=30) and held.acquire(timeout=30)  # both lane threads held
        small = client.post("/v2/contact/batch", json={
            "a_size": [1, 1, 1], "b_size": [1, 1, 1], "a_position": [0, 0, 0],
            "b_position": [[0, 0, 0.99]] * 10, "a_quaternion": [1, 0, 0, 0],
            "b_quaternion": [1, 0, 0, 0]})
        assert small.status_code == 200 and small.json()["colliding"] == [True] * 10
    finally:
        release.set()
        for thread in large:
            thread.join(60)


def test_large_work_past_the_queue_is_503_before_it_starts(make_client, monkeypatch):
    client = make_client(scene="quay_crane_detail", max_batch_workers=1,
                         max_queued_large_work=1)
    held, release = threading.Semaphore(0), threading.Event()
    solve = service_solve._solve

    def holding(dispatcher, plan, caps):  # the solve step, in its lane's thread
        if plan.work > client.app.state.runtime.settings.small_work_max:
            held.release()
            release.wait(30)
        return solve(dispatcher, plan, caps)

    monkeypatch.setattr(service_solve, "_solve", holding)
    answers = []

    def large():
        answers.append(client.post("/v2/contact/batch", content=_containers(2_000),
                                   headers=NPZ).status_code)

    running = threading.Thread(target=large)
    running.start()
    try:
        assert held.acquire(timeout=30)  # the one large thread is held
        waiting = threading.Thread(target=large)
        waiting.start()
        lanes = client.app.state.runtime.lanes
        for _ in range(300):  # the second one's solve step waits in the queue
            if lanes.waiting == 1:
                break
            time.sleep(0.01)
        assert lanes.waiting == 1
        refused = client.post("/v2/contact/batch", content=_containers(2_000), headers=NPZ)
        assert_error(refused, 503, error="overloaded")
        assert refused.headers["retry-after"]
        assert 'reason="large_work_queue"} 1.0' in client.get("/metrics").text
    finally:
        release.set()
        running.join(60)
        waiting.join(60)
    assert answers == [200, 200]


def test_an_oversized_body_sent_whole_gets_its_413(server):
    """http.client sends the whole body before it reads the answer: the 413 must reach it
    (not a reset connection)."""
    conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    body = b'{"a": ' + b" " * (12 << 20) + b"}"
    conn.request("POST", "/v2/contact", body, {"Content-Type": "application/json"})
    response = conn.getresponse()
    assert response.status == 413
    assert json.loads(response.read())["error"] == "body_too_large"


@pytest.mark.slow
def test_a_real_server_stops_computing_when_its_client_leaves_and_gives_memory_back(
        server_factory):
    proc = server_factory("--scene", "quay_crane_detail")
    pid = proc.proc.pid
    ready = memory_kib(pid)["VmRSS"] * 1024
    body = _containers(1_000, [0.05, 0.0, 0.0])  # ~10 s of work
    import socket

    sock = socket.create_connection(("127.0.0.1", proc.port))
    sock.sendall(b"POST /v2/contact/batch HTTP/1.1\r\nHost: x\r\nContent-Type: "
                 b"application/x-npz\r\nContent-Length: %d\r\n\r\n" % len(body) + body)
    time.sleep(0.5)
    sock.close()
    time.sleep(1.5)  # the work stops at its next slice
    spent = cpu_seconds(pid)
    time.sleep(3.0)
    assert cpu_seconds(pid) - spent < 0.5  # nothing more computed
    status, _, _ = _post(proc.port, _containers(2_000))  # a large answer, then idle
    assert status == 200
    time.sleep(10.0)
    assert memory_kib(pid)["VmRSS"] * 1024 <= ready + (64 << 20)


def _post(port: int, body: bytes):
    from tests.service.hostile.conftest import post

    return post(port, "/v2/contact/batch", body, NPZ, timeout=120)
