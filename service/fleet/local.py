"""A fleet on one machine: N ``impactnet serve`` replicas on loopback ports behind an nginx front
configured from the shipped template (:mod:`impactnet.service.fleet.nginx_conf`).

    python -m impactnet.service.fleet.local --replicas 2 --port 8000 -- --default-mode exact

runs until Ctrl+C, then stops the front and the replicas. The scale-out measurements
(docs/fleet.md) and the fleet tests (tests/fleet) use it; in production the same template
runs in docker/compose.yaml. Replica ``i`` is named ``r<i>`` (``IMPACTNET_REPLICA_NAME``,
which the replica reports in its answers' ``X-Replica`` header).
"""
from __future__ import annotations

import argparse
import contextlib
import http.client
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from impactnet.service.fleet import nginx_conf

#: Seconds a replica (scene, bundle, smoke test) or the front may take to answer /readyz 200.
READY_TIMEOUT_S = 120.0
#: Seconds a process may take to exit after SIGTERM before it is killed.
STOP_TIMEOUT_S = 40.0
#: Where Debian installs nginx when /usr/sbin is not on PATH.
NGINX_FALLBACK = "/usr/sbin/nginx"


def find_nginx() -> str | None:
    """The nginx binary: PATH, then /usr/sbin/nginx; None where there is none."""
    found = shutil.which("nginx")
    if found:
        return found
    return NGINX_FALLBACK if os.access(NGINX_FALLBACK, os.X_OK) else None


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def status_of(port: int, path: str = "/readyz", timeout: float = 2.0) -> int | None:
    """HTTP status of ``GET path`` on 127.0.0.1:port; None where nothing answers."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        conn.request("GET", path)
        response = conn.getresponse()
        response.read()
        return response.status
    except (OSError, http.client.HTTPException):
        return None
    finally:
        conn.close()


@dataclass
class Process:
    """One process of the fleet, its stdout and stderr in ``log``."""

    name: str
    port: int
    proc: subprocess.Popen
    log: Path

    def output(self) -> str:
        return self.log.read_text(encoding="utf-8", errors="replace")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def terminate(self) -> None:
        """SIGTERM (a replica drains, nginx stops at once)."""
        if self.alive():
            self.proc.send_signal(signal.SIGTERM)

    def stop(self, timeout: float = STOP_TIMEOUT_S) -> int:
        """SIGTERM, then SIGKILL after ``timeout``; the exit status."""
        self.terminate()
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()


def _wait_ready(process: Process, deadline: float) -> None:
    while status_of(process.port) != 200:
        if not process.alive():
            raise RuntimeError(f"{process.name} exited with {process.proc.returncode}:\n"
                               f"{process.output()[-3000:]}")
        if time.monotonic() > deadline:
            raise TimeoutError(f"{process.name} not ready in {READY_TIMEOUT_S} s:\n"
                               f"{process.output()[-3000:]}")
        time.sleep(0.05)


@dataclass
class Fleet:
    """``replicas`` replicas and their front, in a temporary folder (configs, logs, nginx temp
    files). Use as a context manager: everything is stopped and deleted on exit, failures
    included."""

    replicas: int
    serve_args: list[str] = field(default_factory=list)  # flags of every replica
    env: dict[str, str] = field(default_factory=dict)  # environment of every replica
    nginx: str | None = None  # the nginx binary (default: find_nginx())
    port: int = 0  # the front's port (0: a free one)
    template: str | None = None  # the front's template text (default: docker/nginx.conf)
    members: list[Process] = field(default_factory=list)
    front: Process | None = None
    folder: Path | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.front.port}"

    def __enter__(self) -> Fleet:
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def start(self) -> None:
        self.folder = Path(tempfile.mkdtemp(prefix="impactnet-fleet-"))
        # nginx's workers run as an unprivileged user when the master is root: they must be
        # able to enter the folder (the master creates the temp folders for them).
        self.folder.chmod(0o755)
        deadline = time.monotonic() + READY_TIMEOUT_S
        for i in range(1, self.replicas + 1):
            self.members.append(self.start_replica(f"r{i}"))
        for member in self.members:
            _wait_ready(member, deadline)
        self.front = self._start_front()
        _wait_ready(self.front, deadline)

    def start_replica(self, name: str) -> Process:
        """Start replica ``name`` on a free port (not waiting for it to be ready)."""
        port = free_port()
        log = self.folder / f"{name}.log"
        env = {**os.environ, "PYTHONUNBUFFERED": "1", **self.env,
               "IMPACTNET_REPLICA_NAME": name}
        with open(log, "ab") as out:
            proc = subprocess.Popen([sys.executable, "-m", "impactnet.service", "--port",
                                     str(port), *self.serve_args], env=env, stdout=out,
                                    stderr=subprocess.STDOUT)
        return Process(name, port, proc, log)

    def nginx_values(self, port: int) -> dict[str, str]:
        """The template's values for this fleet: its replicas' ports, the front's ``port``."""
        return nginx_conf.loopback_values([f"127.0.0.1:{m.port}" for m in self.members],
                                          f"127.0.0.1:{port}", str(self.folder))

    def _start_front(self) -> Process:
        binary = self.nginx or find_nginx()
        if binary is None:
            raise FileNotFoundError("nginx is not installed (Debian: apt-get install nginx)")
        port = self.port or free_port()
        config = self.folder / "nginx.conf"
        text = nginx_conf.render(self.nginx_values(port), self.template)
        config.write_text(text, encoding="utf-8")
        log = self.folder / "nginx.log"
        with open(log, "ab") as out:
            proc = subprocess.Popen([binary, "-p", str(self.folder), "-e",
                                     str(self.folder / "error.log"), "-c", str(config), "-g",
                                     "daemon off;"], stdout=out, stderr=subprocess.STDOUT)
        return Process("front", port, proc, log)

    def stop(self) -> None:
        """Stop the front, then every replica (SIGTERM, SIGKILL if one hangs); delete the
        folder."""
        for process in [p for p in (self.front, *self.members) if p is not None]:
            with contextlib.suppress(OSError):
                process.stop()
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.service.fleet.local",
                                     description="N replicas behind an nginx front on "
                                     "loopback, until Ctrl+C.")
    parser.add_argument("--replicas", type=int, default=2)
    parser.add_argument("--port", type=int, default=8000, help="the front's port")
    parser.add_argument("serve_args", nargs="*", help="flags of every replica (after --)")
    args = parser.parse_args(argv)
    # SIGINT too: a background job of a script starts with SIGINT ignored.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _interrupt)
    with contextlib.suppress(KeyboardInterrupt), \
            Fleet(args.replicas, args.serve_args, port=args.port) as fleet:
        ports = ", ".join(f"{m.name} 127.0.0.1:{m.port}" for m in fleet.members)
        print(f"front {fleet.url} -> {ports}; Ctrl+C stops", flush=True)
        while all(p.alive() for p in (fleet.front, *fleet.members)):
            time.sleep(0.5)
    return 0


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    raise SystemExit(main())
