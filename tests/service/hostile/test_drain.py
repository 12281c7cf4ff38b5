"""Issue 23, item 6: a shutdown answers the keep-alive clients instead of resetting them.

Reproducer: with the old default ``drain_delay_s = 0``, 20 of 20 keep-alive clients that sent a
request right after SIGTERM got a reset: the listener and the idle connections closed at once.
Now the default drain delay keeps them open for a second, /readyz says 503 meanwhile, and every
answer carries ``Connection: close``, so each client is answered and then reconnects elsewhere.
"""
from __future__ import annotations

import http.client
import threading

import orjson
import pytest

from tests.service.conftest import PAIR, ServerProcess, get

CLIENTS = 20


@pytest.mark.slow
def test_keep_alive_clients_are_answered_during_the_drain():
    proc = ServerProcess(args=["--no-access-log"])  # the default drain delay
    try:
        proc.wait_ready()
        body = orjson.dumps(PAIR)
        headers = {"Content-Type": "application/json"}
        connections = [http.client.HTTPConnection("127.0.0.1", proc.port, timeout=10)
                       for _ in range(CLIENTS)]
        for conn in connections:  # one answered request each; the connection stays open
            conn.request("POST", "/v2/contact", body, headers)
            response = conn.getresponse()
            assert response.status == 200 and response.getheader("connection") != "close"
            response.read()
        proc.terminate()
        assert get(proc.port, "/readyz")[0] == 503  # draining, still listening
        answers: list = [None] * CLIENTS

        def again(i: int) -> None:
            try:
                connections[i].request("POST", "/v2/contact", body, headers)
                response = connections[i].getresponse()
                answers[i] = (response.status, response.getheader("connection"),
                              response.read())
            except OSError as exc:  # a reset: what the clients got before the fix
                answers[i] = exc

        threads = [threading.Thread(target=again, args=(i,)) for i in range(CLIENTS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(10)
        assert proc.proc.wait(30) == 0
    finally:
        proc.cleanup()
    failures = [a for a in answers if not isinstance(a, tuple)]
    assert not failures, failures[:3]
    assert all(status == 200 and connection == "close" and orjson.loads(data)["colliding"]
               for status, connection, data in answers)
