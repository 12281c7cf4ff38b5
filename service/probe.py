"""Probes of a server process from outside, for the hostile-client tests and `impactnet bench
hostile`: /healthz latency sampled from a process of its own, the server's memory and CPU time
as the kernel reports them, one raw POST. Loopback only; standard library and NumPy."""
from __future__ import annotations

import http.client
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

#: Seconds between two /healthz probes of the sampler: ~50 samples a second.
PROBE_INTERVAL_S = 0.02


_PROBE_SCRIPT = """
import http.client, signal, sys, time
# SIGINT ends the probe even where the test runner was started with SIGINT ignored (a
# background job inherits SIG_IGN, and Python then installs no KeyboardInterrupt handler)
signal.signal(signal.SIGINT, signal.default_int_handler)
port, interval, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
samples = []
try:
    while True:
        started = time.perf_counter()
        try:
            conn.request("GET", "/healthz")
            response = conn.getresponse()
            response.read()
            ok = response.status == 200
        except OSError:
            ok = False
            conn.close()
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        ms = (time.perf_counter() - started) * 1e3 if ok else 10000.0
        samples.append(f"{time.monotonic():.4f} {ms:.3f}")
        time.sleep(interval)
except KeyboardInterrupt:
    pass
finally:
    with open(out, "w") as f:
        f.write("\\n".join(samples))
"""


class HealthSampler:
    """Probes GET /healthz every :data:`PROBE_INTERVAL_S` on one keep-alive connection from a
    process of its own (so that the test's own threads do not delay the probes), and keeps
    each probe's latency in ms (``ms``) and its :func:`time.monotonic` time (``at``); a probe
    that fails counts as 10 s."""

    def __init__(self, port: int) -> None:
        self.port, self.ms, self.at = port, [], []
        fd, self._out = tempfile.mkstemp(prefix="impactnet-healthz-", suffix=".txt")
        os.close(fd)

    def __enter__(self) -> HealthSampler:
        self._proc = subprocess.Popen([sys.executable, "-c", _PROBE_SCRIPT, str(self.port),
                                       str(PROBE_INTERVAL_S), self._out])
        time.sleep(0.3)  # the interpreter starts
        return self

    def __exit__(self, *exc) -> None:
        self._proc.send_signal(signal.SIGINT)
        self._proc.wait(15)
        with open(self._out) as f:
            pairs = [line.split() for line in f.read().splitlines() if line.strip()]
        os.unlink(self._out)
        self.at = [float(a) for a, _ in pairs]
        self.ms = [float(m) for _, m in pairs]

    def p99(self) -> float:
        return float(np.percentile(self.ms, 99))


def memory_kib(pid: int) -> dict[str, int]:
    """VmRSS (resident now) and VmHWM (peak resident) of a process, KiB."""
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(value.split()[0])
    return out


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far, seconds (Linux /proc)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def post(port: int, path: str, body: bytes, headers: dict | None = None,
         timeout: float = 30.0) -> tuple[int, dict, bytes]:
    """One POST on a fresh loopback connection: (status, lower-case headers, body)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        conn.request("POST", path, body, {"Content-Type": "application/json", **(headers or {})})
        response = conn.getresponse()
        return (response.status, {k.lower(): v for k, v in response.getheaders()},
                response.read())
    finally:
        conn.close()
