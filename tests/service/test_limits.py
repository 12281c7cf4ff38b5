"""Body size limit (413, while streaming), concurrency limit (503 + Retry-After), the catch-all
500, readiness while loading / failed / draining. ASGI-level where timing matters."""
from __future__ import annotations

import asyncio
import json
import threading

import httpx
import pytest

from impactnet.models.box.exact import box_box
from impactnet.service.app import create_app
from tests.service.conftest import PAIR, assert_error, serve_exact_with, test_settings


async def _call(app, method: str, path: str, chunks: list[bytes], headers=()):
    """Drive the ASGI app directly; returns (status, headers, body, chunks consumed)."""
    consumed = 0
    sent = []

    async def receive():
        nonlocal consumed
        if consumed < len(chunks):
            consumed += 1
            return {"type": "http.request", "body": chunks[consumed - 1],
                    "more_body": consumed < len(chunks)}
        await asyncio.sleep(3600)  # a client that never sends more

    async def send(message):
        sent.append(message)

    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1",
             "method": method, "path": path, "raw_path": path.encode(), "query_string": b"",
             "root_path": "", "scheme": "http", "server": ("127.0.0.1", 8000),
             "client": ("127.0.0.1", 5000), "headers": [(k.encode(), v.encode())
                                                         for k, v in headers]}
    await asyncio.wait_for(app(scope, receive, send), timeout=10)
    start = next(m for m in sent if m["type"] == "http.response.start")
    body = b"".join(m.get("body", b"") for m in sent if m["type"] == "http.response.body")
    return start["status"], dict(start["headers"]), body, consumed


async def _ready_app(**overrides):
    app = create_app(test_settings(**overrides))
    await app.state.runtime.load()
    return app


@pytest.mark.parametrize("path", ["/v2/contact", "/v2/contact/batch"])
def test_streamed_body_over_the_limit_is_413_and_its_rest_is_dropped_unkept(path):
    async def main():
        app = await _ready_app(max_body_bytes=10 * 1024)
        chunks = [b" " * 1024] * 100  # 100 KiB, chunked (no Content-Length)
        status, headers, body, consumed = await _call(
            app, "POST", path, chunks, [("content-type", "application/json")])
        return status, body, consumed, app.state.runtime.budget.peak

    status, body, consumed, peak = asyncio.run(main())
    assert status == 413
    assert json.loads(body)["error"] == "body_too_large"
    # the rest is read (so that a client sending it all gets to read the 413), never kept
    assert consumed == 100 and peak <= 11 * 1024


def test_a_declared_oversized_body_is_read_and_dropped_before_its_413():
    async def main():
        app = await _ready_app(max_body_bytes=10 * 1024)
        chunks = [b" " * 1024] * 100
        status, headers, body, consumed = await _call(
            app, "POST", "/v2/contact/batch", chunks,
            [("content-type", "application/json"), ("content-length", str(100 * 1024))])
        return status, headers, consumed, app.state.runtime.budget.peak

    status, headers, consumed, peak = asyncio.run(main())
    assert status == 413 and headers[b"connection"] == b"close"
    assert consumed == 100 and peak == 0  # read to its end, nothing stored


def test_an_oversized_body_that_waits_for_100_continue_is_413_unread():
    async def main():
        app = await _ready_app(max_body_bytes=10 * 1024)
        return await _call(app, "POST", "/v2/contact/batch", [b" " * 1024] * 100,
                           [("content-type", "application/json"),
                            ("content-length", str(100 * 1024)), ("expect", "100-continue")])

    status, headers, body, consumed = asyncio.run(main())
    assert status == 413 and consumed == 0


def test_declared_content_length_over_the_limit_is_413_unread():
    async def main():
        app = await _ready_app(max_body_bytes=10 * 1024)
        return await _call(app, "POST", "/v2/contact/batch", [b"{}"],
                           [("content-type", "application/json"),
                            ("content-length", str(10**9))])

    status, headers, body, consumed = asyncio.run(main())
    assert status == 413 and consumed == 0
    assert headers[b"connection"] == b"close"
    assert json.loads(body)["error"] == "body_too_large"


def test_testclient_oversize_body_is_413(make_client):
    c = make_client(max_body_bytes=2048)
    response = c.post("/v2/contact/batch", content=b"[" + b"0," * 5000 + b"0]",
                      headers={"Content-Type": "application/json"})
    assert_error(response, 413, None, "body_too_large")
    assert c.post("/v2/contact", json=PAIR).status_code == 200


class _Gate:
    """An exact solver that waits for a signal, to keep a request in flight."""

    mode = "exact"

    def __init__(self, failing: bool = False) -> None:
        self.started, self.release = threading.Event(), threading.Event()
        self.failing = failing

    def __call__(self, *args):
        if self.failing:
            raise RuntimeError("a deliberate bug")
        self.started.set()
        self.release.wait(10)
        return box_box(*args)


#: Two cube pairs: a batch, so that its predictor runs in a worker thread, not on the loop.
SMALL_BATCH = {"a_size": [2, 2, 2], "a_position": [[0, 0, 0]] * 2, "a_quaternion": [1, 0, 0, 0],
               "b_size": [2, 2, 2], "b_position": [0, 0, 1.9], "b_quaternion": [1, 0, 0, 0]}


async def hold_a_slot(app, client) -> tuple[_Gate, asyncio.Task]:
    """A batch that holds a compute slot until ``gate.release`` is set; its task."""
    gate = _Gate()
    serve_exact_with(app, gate)
    held = asyncio.create_task(client.post("/v2/contact/batch", json=SMALL_BATCH))
    await asyncio.to_thread(gate.started.wait, 10)
    return gate, held


def test_concurrency_limit_is_503_with_retry_after():
    async def main():
        app = await _ready_app(max_concurrency=1, retry_after_s=2)
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            gate, first = await hold_a_slot(app, client)
            second = await client.post("/v2/contact", json=PAIR)
            probes = [await client.get(p) for p in ("/healthz", "/readyz", "/metrics")]
            gate.release.set()
            return await first, second, probes

    first, second, probes = asyncio.run(main())
    assert first.status_code == 200
    assert_error(second, 503, None, "overloaded")
    assert second.headers["retry-after"] == "2"
    assert [p.status_code for p in probes] == [200, 200, 200]


def test_a_bug_is_a_json_500_with_request_id(make_client, caplog):
    c = make_client()
    serve_exact_with(c.app, _Gate(failing=True))
    response = c.post("/v2/contact", json=PAIR, headers={"X-Request-ID": "bug-1"})
    body = assert_error(response, 500, None, "internal_error")
    assert body["request_id"] == "bug-1" and response.headers["x-request-id"] == "bug-1"
    assert any("a deliberate bug" in (r.exc_text or "") or r.exc_info for r in caplog.records)


def test_readyz_is_503_while_loading_then_200(monkeypatch):
    from fastapi.testclient import TestClient

    import impactnet.service.runtime as runtime_module

    release = threading.Event()
    real = runtime_module.build_state

    def slow_build(*args):
        release.wait(10)
        return real(*args)

    monkeypatch.setattr(runtime_module, "build_state", slow_build)
    app = create_app(test_settings(load_in_background=True))
    with TestClient(app, raise_server_exceptions=False) as c:
        assert c.get("/healthz").status_code == 200
        loading = c.get("/readyz")
        assert loading.status_code == 503 and "loading" in loading.json()["reason"]
        assert loading.headers["retry-after"] == "1"
        assert_error(c.post("/v2/contact", json=PAIR), 503, None, "not_ready")
        release.set()
        for _ in range(200):
            if c.get("/readyz").status_code == 200:
                break
            threading.Event().wait(0.02)
        assert c.get("/readyz").status_code == 200
        assert c.post("/v2/contact", json=PAIR).status_code == 200


def test_readyz_reports_a_failed_load(make_client):
    c = make_client(scene="no_such_scene")
    response = c.get("/readyz")
    assert response.status_code == 503
    assert "loading failed" in response.json()["reason"]
    assert "no_such_scene" in response.json()["reason"]
    assert_error(c.post("/v2/contact", json=PAIR), 503, None, "not_ready")


def test_draining_turns_readyz_503_but_still_serves(make_client):
    c = make_client()
    assert c.get("/readyz").status_code == 200
    c.app.state.runtime.begin_drain()
    response = c.get("/readyz")
    assert response.status_code == 503 and "draining" in response.json()["reason"]
    assert c.post("/v2/contact", json=PAIR).status_code == 200  # in-flight / late: served


def test_a_missing_bundle_is_refused_with_the_reason(make_client):
    c = make_client(bundle="models/bundles/no_such_scene")
    response = c.get("/readyz")
    assert response.status_code == 503 and "bundle" in response.json()["reason"]
