"""`impactnet bench hostile`: what the hostile probe's requests cost a replica (issue #31).

    impactnet bench hostile [--quick] [--out docs/benchmarks] [--scene quay_crane_detail]

Each reproducer (:mod:`impactnet.training.bench.http.hostile_attacks`) is sent to a fresh server
(``python -m impactnet.service``, the scene's bundle, default settings) on 127.0.0.1 while
/healthz is probed from another process and the server's resident memory is sampled. Per
attack: the statuses, the slowest request's wall time, the peak resident memory above the
ready one, /healthz p99, the CPU seconds spent, and the resident memory 10 s after. Then three
mechanisms: a 10-pair batch's latency while two large batches run; the CPU a request burns
after its client disconnects at 0.5 s; the wall time of a request past a 2 s deadline.

Goals: peak within ready + the memory budget and within 1 GiB; every request within the
deadline; /healthz p99 <= 50 ms; the 10-pair batch <= 0.5 s; idle memory back within ready +
64 MiB 10 s after. The report goes to ``hostile.md`` in ``--out`` (and is printed).
"""
from __future__ import annotations

import contextlib
import socket
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from impactnet.service.probe import HealthSampler, cpu_seconds, memory_kib, post
from impactnet.service.settings import Settings
from impactnet.training.bench.http.hostile_attacks import (
    Attack,
    MiB,
    attacks,
    large_batch,
    small_batch,
)
from impactnet.training.bench.http.loopback import free_port

#: Seconds after the last request before the idle memory is read.
IDLE_AFTER_S = 10.0
#: Seconds between two samples of the server's resident memory.
RSS_SAMPLE_S = 0.02
#: The deadline of the deadline check (seconds), short so that the check is quick.
SHORT_DEADLINE_S = 2.0
NPZ = "application/x-npz"


@contextlib.contextmanager
def server(scene: str, *args: str):
    """A ready server on a free loopback port: yields (port, pid)."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "impactnet.service", "--port", str(port),
                             "--scene", scene, "--no-access-log", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            with contextlib.suppress(OSError):
                if post_get(port, "/readyz") == 200:
                    break
            if proc.poll() is not None:
                raise RuntimeError(f"the server exited with {proc.returncode}")
            time.sleep(0.1)
        yield port, proc.pid
    finally:
        proc.terminate()
        proc.wait(60)


def post_get(port: int, path: str) -> int:
    import http.client

    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
    try:
        conn.request("GET", path)
        response = conn.getresponse()
        response.read()
        return response.status
    finally:
        conn.close()


class PeakMemory:
    """Samples a process's resident memory every :data:`RSS_SAMPLE_S` while in use."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak, self._stop = pid, 0, threading.Event()

    def __enter__(self) -> PeakMemory:
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def _sample(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, memory_kib(self.pid)["VmRSS"] * 1024)
            time.sleep(RSS_SAMPLE_S)

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()


def _send(port: int, attack: Attack) -> tuple[int, float]:
    headers = {"Content-Type": NPZ, "Accept": NPZ} if attack.npz else {}
    started = time.perf_counter()
    status, _, _ = post(port, attack.path, attack.body, headers, timeout=120)
    return status, time.perf_counter() - started


def run_attack(scene: str, attack: Attack) -> dict:
    """One attack on a fresh server (module docstring)."""
    with server(scene) as (port, pid):
        ready = memory_kib(pid)["VmRSS"] * 1024
        cpu = cpu_seconds(pid)
        with HealthSampler(port) as health, PeakMemory(pid) as memory, \
                ThreadPoolExecutor(attack.parallel) as pool:
            answers = list(pool.map(lambda _: _send(port, attack), range(attack.parallel)))
        spent = cpu_seconds(pid) - cpu
        time.sleep(IDLE_AFTER_S)
        idle = memory_kib(pid)["VmRSS"] * 1024
    statuses = sorted({s for s, _ in answers})
    return {"name": attack.name, "what": attack.what, "statuses": statuses,
            "expected": all(s in attack.expect for s in statuses),
            "wall_s": max(t for _, t in answers), "ready_mib": ready / MiB,
            "peak_over_ready_mib": (memory.peak - ready) / MiB, "peak_mib": memory.peak / MiB,
            "healthz_p99_ms": health.p99(), "cpu_s": spent,
            "idle_over_ready_mib": (idle - ready) / MiB}


def head_of_line(scene: str, repeats: int = 10) -> dict:
    """A 10-pair batch's latency while two large compound batches run."""
    with server(scene) as (port, _):
        large = large_batch()
        with ThreadPoolExecutor(2) as pool:
            running = [pool.submit(post, port, "/v2/contact/batch", large,
                                   {"Content-Type": NPZ, "Accept": NPZ}, 120) for _ in range(2)]
            time.sleep(1.0)
            latency = []
            for _ in range(repeats):
                started = time.perf_counter()
                status, _, _ = post(port, "/v2/contact/batch", small_batch())
                latency.append(time.perf_counter() - started)
                time.sleep(0.1)
            still_running = sum(not f.done() for f in running)
    return {"small_p50_s": float(np.median(latency)), "small_max_s": max(latency),
            "status": status, "large_running_at_end": still_running}


def disconnect(scene: str) -> dict:
    """CPU seconds a large request burns after its client leaves at 0.5 s."""
    body = large_batch()
    with server(scene) as (port, pid):
        sock = socket.create_connection(("127.0.0.1", port))
        sock.sendall(b"POST /v2/contact/batch HTTP/1.1\r\nHost: x\r\nContent-Type: "
                     b"application/x-npz\r\nContent-Length: %d\r\n\r\n" % len(body) + body)
        time.sleep(0.5)
        sock.close()
        cpu = cpu_seconds(pid)
        time.sleep(5.0)
        return {"cpu_after_disconnect_s": cpu_seconds(pid) - cpu}


def deadline(scene: str) -> dict:
    """Wall time and status of a request that runs past a short deadline."""
    with server(scene, "--compute-deadline", str(SHORT_DEADLINE_S)) as (port, _):
        started = time.perf_counter()
        status, _, _ = post(port, "/v2/contact/batch", large_batch(4_000),
                            {"Content-Type": NPZ, "Accept": NPZ}, 120)
        return {"deadline_s": SHORT_DEADLINE_S, "status": status,
                "wall_s": time.perf_counter() - started}


def run(quick: bool = False, out: str | None = None,
        scene: str = "quay_crane_detail") -> dict:
    """Every measurement; the report printed and written to ``out``/hostile.md."""
    from impactnet.training.bench.http.hostile_report import markdown

    settings = Settings()
    results = {"attacks": [run_attack(scene, a) for a in attacks(quick)],
               "head_of_line": head_of_line(scene), "disconnect": disconnect(scene),
               "deadline": deadline(scene), "budget_mib": settings.memory_budget_bytes / MiB,
               "deadline_s": settings.compute_deadline_s, "quick": quick, "scene": scene}
    text = markdown(results)
    print(text)
    if out:
        Path(out).mkdir(parents=True, exist_ok=True)
        (Path(out) / "hostile.md").write_text(text, encoding="utf-8")
    return results
