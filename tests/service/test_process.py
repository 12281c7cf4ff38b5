"""A real server process (``python -m impactnet.service``, what ``impactnet serve`` runs) on a free
loopback port: started, queried, oversize bodies refused unread, SIGTERM -> drain -> graceful
exit with the in-flight request answered."""
from __future__ import annotations

import json
import re
import socket
import threading
import time

import numpy as np

from impactnet.service.client import ImpactClient
from tests.service.conftest import PAIR, ServerProcess, get
from tests.service.test_batch import poses


def test_started_and_queried(server):
    status, body = get(server.port, "/readyz")
    assert status == 200 and json.loads(body)["ready"] is True
    with ImpactClient(server.url) as client:
        answer = client.contact(PAIR["a"], PAIR["b"])
        assert answer["colliding"] and answer["contact_type"] != "none"
    status, text = get(server.port, "/metrics")
    assert status == 200 and b"impactnet_http_requests_total" in text
    assert get(server.port, "/docs")[0] == 200


def test_oversize_content_length_is_refused_before_the_body_is_sent(server):
    with socket.create_connection(("127.0.0.1", server.port), timeout=5) as sock:
        sock.sendall(b"POST /v2/contact/batch HTTP/1.1\r\nHost: x\r\n"
                     b"Content-Type: application/json\r\nContent-Length: 1000000000\r\n\r\n")
        started = time.monotonic()
        reply = b""
        while chunk := sock.recv(65536):  # the server closes the connection after the 413
            reply += chunk
        assert time.monotonic() - started < 2
    assert reply.startswith(b"HTTP/1.1 413"), reply[:200]
    assert b"body_too_large" in reply


def _in_flight(port: int) -> float:
    status, text = get(port, "/metrics")
    match = re.search(rb"impactnet_http_in_flight_requests ([0-9.]+)", text)
    return float(match.group(1)) if match else 0.0


def test_sigterm_drains_and_finishes_the_in_flight_request():
    proc = ServerProcess(args=["--drain-delay", "0.5", "--graceful-timeout", "60"])
    try:
        proc.wait_ready()
        columns = poses(60_000, seed=11)
        result = {}

        def slow_request():
            with ImpactClient(proc.url, timeout=60) as client:
                try:
                    result["answer"] = client.batch(columns, binary=False)
                except Exception as exc:  # noqa: BLE001 - reported by the assertion below
                    result["error"] = exc

        worker = threading.Thread(target=slow_request)
        worker.start()
        deadline = time.monotonic() + 30
        while _in_flight(proc.port) < 1 and time.monotonic() < deadline:
            time.sleep(0.005)
        assert _in_flight(proc.port) >= 1, "the batch never got in flight"
        proc.terminate()
        status, body = get(proc.port, "/readyz")  # inside the drain delay: still listening
        assert status == 503 and "draining" in json.loads(body)["reason"]
        worker.join(60)
        assert "error" not in result, result.get("error")
        assert result["answer"]["point"].shape == (60_000, 3)
        assert proc.proc.wait(30) == 0
        log = proc.output()
        assert "draining" in log and "Finished server process" in log
        assert '"level":"error"' not in log
    finally:
        proc.cleanup()


def test_bad_scene_exits_2_before_binding():
    proc = ServerProcess(args=["--scene", "no_such_scene"])
    try:
        assert proc.proc.wait(60) == 2
        assert "no_such_scene" in proc.output()
    finally:
        proc.cleanup()


def test_env_settings_reach_the_process():
    proc = ServerProcess(env={"IMPACTNET_MAX_BATCH_PAIRS": "7", "IMPACTNET_SCENE": "paper"})
    try:
        proc.wait_ready()
        with ImpactClient(proc.url) as client:
            models = client.models()
            assert models["limits"]["max_batch_pairs"] == 7
            assert models["scene"]["name"] == "paper"
            out = client.batch({"a_object": "cube", "a_position": np.zeros((7, 3)),
                                "a_quaternion": [1, 0, 0, 0], "b_object": "cube",
                                "b_position": [0, 0, 1.9], "b_quaternion": [1, 0, 0, 0]})
            assert out["colliding"].all()
        assert proc.stop() == 0
    finally:
        proc.cleanup()
