"""Fixtures of the service tests: in-process apps (TestClient) and real server processes."""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import http.client
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from impactnet.service.app import create_app
from impactnet.service.settings import Settings

REPO = Path(__file__).resolve().parents[2]

#: The paper's cubes: B rests on A's top face, 5 cm deep, tilted 0.05 rad about x.
PAIR = {
    "a": {"size": [2.0, 2.0, 2.0], "position": [0.0, 0.0, 0.0], "quaternion": [1, 0, 0, 0]},
    "b": {"size": [2.0, 2.0, 2.0], "position": [0.5, 0.3, 1.95], "euler": [0.05, 0.0, 0.0]},
}


def pair(**changes) -> dict:
    """A deep copy of PAIR with ``a_size=...`` style changes (None deletes the key)."""
    body = copy.deepcopy(PAIR)
    for key, value in changes.items():
        if "_" in key and key[:2] in ("a_", "b_"):
            side, field = key.split("_", 1)
            if value is None:
                body[side].pop(field, None)
            else:
                body[side][field] = value
        elif value is None:
            body.pop(key, None)
        else:
            body[key] = value
    return body


def test_settings(**overrides) -> Settings:
    """Settings of an in-process test app: loaded before the first request, no access log,
    and no learned bundle unless one is given (the shipped default bundle, when there is
    one, must not change what these tests see), and the heap not frozen (many apps are built
    in one process)."""
    base = {"load_in_background": False, "access_log": False, "bundle": "none",
            "freeze_heap": False}
    return Settings(**(base | overrides))


test_settings.__test__ = False  # a helper, not a test


@pytest.fixture(autouse=True)
def _restore_thread_env(monkeypatch):
    """``impactnet.service.cli.run`` pins BLAS thread counts in ``os.environ``; tests that call it
    in process must not leave them behind for later tests (monkeypatch restores them)."""
    from impactnet.service.cli import THREAD_ENV

    for name in THREAD_ENV:
        monkeypatch.setenv(name, os.environ.get(name, "1"))


@pytest.fixture
def make_client():
    """``make_client(**settings) -> TestClient`` with the lifespan run (state loaded)."""
    stack = contextlib.ExitStack()

    def make(**overrides) -> TestClient:
        app = create_app(test_settings(**overrides))
        return stack.enter_context(TestClient(app, raise_server_exceptions=False))

    with stack:
        yield make


@pytest.fixture(scope="module")
def client():
    """A ready TestClient with the default scene and default limits."""
    with TestClient(create_app(test_settings()), raise_server_exceptions=False) as c:
        yield c


def serve_exact_with(app, predictor) -> None:
    """Serve ``predictor`` (``box_box``'s signature and answer) as ``app``'s exact box solver:
    a serving state whose dispatcher's exact link is ``predictor``, installed as a reload
    installs one."""
    runtime = app.state.runtime
    state = dataclasses.replace(runtime.serving,
                                predictors=runtime.serving.predictors | {"exact": predictor})
    state.dispatcher.box_predictors["exact"] = predictor
    runtime.install(state)


def assert_error(response, status: int, field: str | None = None, error: str | None = None):
    """Status first, then the envelope: error code, and a detail item naming ``field``."""
    assert response.status_code == status, response.text
    body = response.json()
    assert set(body) >= {"error", "message", "detail", "request_id"}, body
    if error is not None:
        assert body["error"] == error, body
    if field is not None:
        fields = [d["field"] for d in body["detail"]]
        assert any(f == field or f.startswith(field + "[") or f.startswith(field + ".")
                   for f in fields), (field, body)
    return body


# ----------------------------------------------------------------------- real servers


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def get(port: int, path: str, timeout: float = 5.0) -> tuple[int, bytes]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        conn.request("GET", path)
        response = conn.getresponse()
        return response.status, response.read()
    finally:
        conn.close()


class ServerProcess:
    """``python -m impactnet.service`` (what ``impactnet serve`` runs) on a free loopback port; with
    ``--bundle none`` unless ``args`` or ``env`` name a bundle (``bundle_default=True``
    leaves the shipped default bundle to the server). ``command`` replaces ``python -m
    impactnet.service`` (e.g. an installed ``impactnet serve``)."""

    def __init__(self, python: str = sys.executable, args=(), env=None, cwd=REPO,
                 bundle_default: bool = False, command=None) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        if not bundle_default and "--bundle" not in args and "IMPACTNET_BUNDLE" not in (env or {}):
            args = [*args, "--bundle", "none"]
        launcher = list(command) if command else [python, "-m", "impactnet.service"]
        cmd = [*launcher, "--port", str(self.port), *args]
        full_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
        # A file, not a pipe: nobody reads a pipe while the server runs, and a full pipe
        # would block the server's logging. O_APPEND: our reads never move its writes.
        fd, self.log_path = tempfile.mkstemp(prefix="impactnet-serve-", suffix=".log")
        os.close(fd)
        with open(self.log_path, "ab") as log:
            self.proc = subprocess.Popen(cmd, cwd=cwd, env=full_env, stdout=log,
                                         stderr=subprocess.STDOUT)

    def wait_ready(self, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited with {self.proc.returncode}:\n"
                                   + self.output())
            with contextlib.suppress(OSError):
                if get(self.port, "/readyz", timeout=1.0)[0] == 200:
                    return
            time.sleep(0.05)
        raise TimeoutError("server not ready in time")

    def terminate(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)

    def stop(self, timeout: float = 30.0) -> int:
        """SIGTERM, wait (SIGKILL after ``timeout``); returns the exit status."""
        self.terminate()
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()

    def cleanup(self) -> None:
        self.stop()
        with contextlib.suppress(OSError):
            os.unlink(self.log_path)

    def output(self) -> str:
        """Everything the server logged so far (JSON lines)."""
        with open(self.log_path, "rb") as log:
            return log.read().decode("utf-8", "replace")


@pytest.fixture(scope="module")
def server():
    """A real server process, ready; stopped (SIGTERM) after the module."""
    proc = ServerProcess(args=["--no-access-log"])
    try:
        proc.wait_ready()
        yield proc
    finally:
        proc.cleanup()
