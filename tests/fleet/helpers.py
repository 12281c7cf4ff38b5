"""Helpers of the fleet tests (not a test module): Debian's nginx, installed where missing, in
front of ``impactnet serve`` replicas on loopback (:class:`impactnet.service.fleet.local.Fleet`),
and a bounded client load that records who answered each request with which version.

Everything talks to 127.0.0.1 only; every loop ends by a deadline or a count.
"""
from __future__ import annotations

import http.client
import io
import os
import subprocess
import threading
import time
from dataclasses import dataclass, field

import numpy as np
import orjson

from impactnet.service.fleet import local
from impactnet.training.bench.http.service_speed import poses
from tests.apt_packages import Unavailable, apt_install  # noqa: F401 (the fixtures' skip)

#: Seconds a client waits for one answer before it counts the request as failed.
CLIENT_TIMEOUT_S = 30.0
#: The paper's cubes as raw sizes (every mode answers them; mode exact here).
PAIR = {"a": {"size": [2.0, 2.0, 2.0], "position": [0.0, 0.0, 0.0], "quaternion": [1, 0, 0, 0]},
        "b": {"size": [2.0, 2.0, 2.0], "position": [0.5, 0.3, 1.95], "euler": [0.05, 0.0, 0.0]},
        "mode": "exact"}


def nginx_binary() -> str:
    """Debian's nginx: found on PATH or in /usr/sbin, else installed with apt-get (as the
    PostgreSQL tests do) where we are root; raises :class:`Unavailable` otherwise."""
    found = local.find_nginx()
    if found:
        return found
    apt_install("nginx", "nginx")
    found = local.find_nginx()
    if found is None:
        raise Unavailable("apt-get installed nginx but no nginx binary was found")
    return found


def nginx_version(binary: str) -> tuple[int, ...]:
    """``nginx -v`` as a tuple, e.g. (1, 22, 1)."""
    text = subprocess.run([binary, "-v"], capture_output=True, text=True, timeout=10).stderr
    return tuple(int(x) for x in text.strip().rsplit("/", 1)[-1].split(".")[:3])


def nginx_test(binary: str, config_text: str, folder: str) -> subprocess.CompletedProcess:
    """``nginx -t`` of ``config_text`` written to ``folder/nginx.conf``."""
    path = os.path.join(folder, "nginx.conf")
    with open(path, "w", encoding="utf-8") as f:
        f.write(config_text)
    return subprocess.run([binary, "-t", "-p", folder, "-e", os.path.join(folder, "error.log"),
                           "-c", path], capture_output=True, text=True, timeout=30)


def npz_batch(n: int, seed: int = 0) -> bytes:
    """An npz batch body of ``n`` cube pairs around contact (mode exact): service_speed's poses."""
    buffer = io.BytesIO()
    np.savez(buffer, **poses(n, seed))
    return buffer.getvalue()


@dataclass
class Answer:
    """One request: when it was sent and answered (``time.monotonic``), its status (0: no
    answer, ``error`` says why), and the replica and version headers of the answer."""

    client: int
    sent: float
    received: float
    status: int
    replica: str | None = None
    version: str | None = None
    error: str | None = None


@dataclass
class Load:
    """Clients that send requests one after another on a keep-alive connection each, until
    :meth:`stop` or ``max_requests`` each; every request is recorded in ``answers``. A client
    never retries: a dropped connection or a non-200 answer is a failure, reconnecting
    afterwards.

    ``targets``: one port per client (the front, or a replica directly); ``body`` and
    ``content_type``: what each sends (default: one pair as JSON to /v2/contact)."""

    targets: list[int]
    path: str = "/v2/contact"
    body: bytes = field(default_factory=lambda: orjson.dumps(PAIR))
    content_type: str = "application/json"
    pause_s: float = 0.0  # between two requests of one client
    max_requests: int = 5000  # per client: the loop is bounded even if stop() never comes
    answers: list[Answer] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._threads = [threading.Thread(target=self._client, args=(i, port), daemon=True)
                         for i, port in enumerate(self.targets)]

    def __enter__(self) -> Load:
        for thread in self._threads:
            thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def stop(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(CLIENT_TIMEOUT_S + 5)

    def _client(self, index: int, port: int) -> None:
        headers = {"Content-Type": self.content_type}
        conn = None
        for _ in range(self.max_requests):
            if self._stop.is_set():
                break
            conn = conn or http.client.HTTPConnection("127.0.0.1", port,
                                                      timeout=CLIENT_TIMEOUT_S)
            sent = time.monotonic()
            try:
                conn.request("POST", self.path, self.body, headers)
                response = conn.getresponse()
                data = response.read()
                answer = Answer(index, sent, time.monotonic(), response.status,
                                response.getheader("x-replica"),
                                response.getheader("x-model-version"),
                                None if response.status == 200 else data[:200].decode(
                                    "utf-8", "replace"))
                if (response.getheader("connection") or "").lower() == "close":
                    conn.close()
                    conn = None
            except (OSError, http.client.HTTPException) as exc:
                answer = Answer(index, sent, time.monotonic(), 0, error=repr(exc))
                conn.close()
                conn = None
            with self._lock:
                self.answers.append(answer)
            if self.pause_s:
                self._stop.wait(self.pause_s)
        if conn is not None:
            conn.close()

    def failures(self) -> list[Answer]:
        return [a for a in self.answers if a.status != 200]

    def by(self, client: int) -> list[Answer]:
        """The answers of one client, in the order it sent them."""
        return [a for a in self.answers if a.client == client]


def slow_upload(port: int, body: bytes, duration_s: float, chunks: int = 20,
                path: str = "/v2/contact/batch",
                content_type: str = "application/x-npz") -> tuple[int, str | None, str]:
    """POST ``body`` in ``chunks`` pieces spread over ``duration_s`` (a slow but steady
    client); returns (status (0: no answer), X-Replica, error text)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=CLIENT_TIMEOUT_S)
    try:
        conn.putrequest("POST", path)
        conn.putheader("Content-Type", content_type)
        conn.putheader("Content-Length", str(len(body)))
        conn.endheaders()
        step = -(-len(body) // chunks)
        for start in range(0, len(body), step):
            conn.send(body[start:start + step])
            time.sleep(duration_s / chunks)
        response = conn.getresponse()
        data = response.read()
        return (response.status, response.getheader("x-replica"),
                "" if response.status == 200 else data[:200].decode("utf-8", "replace"))
    except (OSError, http.client.HTTPException) as exc:
        return 0, None, repr(exc)
    finally:
        conn.close()
