"""Helpers of the hostile-client suite: raw loopback sockets, a /healthz sampler, the server's
memory as the kernel reports it. Every test talks to 127.0.0.1 only, with bounded traffic and
time."""
from __future__ import annotations

import contextlib
import socket

import pytest

from impactnet.service.probe import (  # noqa: F401 - the hostile tests' helpers
    PROBE_INTERVAL_S,
    HealthSampler,
    cpu_seconds,
    memory_kib,
    post,
)
from tests.service.conftest import ServerProcess

#: /healthz latency goal while hostile requests are refused or served (ms, issue 23).
HEALTHZ_P99_MS = 100.0


def start_server(*args: str, env: dict | None = None) -> ServerProcess:
    """A ready server (``python -m impactnet.service``) on a free loopback port, mode exact."""
    proc = ServerProcess(args=["--no-access-log", *args], env=env)
    try:
        proc.wait_ready()
    except Exception:
        proc.cleanup()
        raise
    return proc


@pytest.fixture
def server_factory():
    """``server_factory(*args, env=...)``: servers stopped after the test."""
    started: list[ServerProcess] = []

    def make(*args: str, env: dict | None = None) -> ServerProcess:
        started.append(start_server(*args, env=env))
        return started[-1]

    yield make
    for proc in started:
        proc.cleanup()


def stalled_sockets(port: int, count: int, path: str = "/v2/contact",
                    declared: int = 1000) -> list[socket.socket]:
    """``count`` connections that each send the headers and one byte of a ``declared``-byte
    body, then nothing more."""
    out = []
    for _ in range(count):
        sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        sock.sendall(f"POST {path} HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                     f"Content-Length: {declared}\r\n\r\n{{".encode())
        out.append(sock)
    return out


def read_reply(sock: socket.socket, timeout: float) -> bytes:
    """Everything the server sends until it closes the connection (or ``timeout``)."""
    sock.settimeout(timeout)
    reply = b""
    with contextlib.suppress(OSError):
        while chunk := sock.recv(65536):
            reply += chunk
    return reply
