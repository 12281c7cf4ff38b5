"""Loopback plumbing shared by the HTTP benchmarks: a free port, a server process waited on
until it answers, the bare echo server (the floor: what HTTP on loopback costs by itself), and
latency percentiles of repeated calls.

Used by :mod:`impactnet.training.bench.http.service_speed` (the service's latency and throughput),
:mod:`~impactnet.training.bench.http.moe`, :mod:`~impactnet.training.bench.http.hostile` and
:mod:`~impactnet.training.bench.http.predictors`.
"""
from __future__ import annotations

import contextlib
import socket
import subprocess
import sys
import time

import numpy as np

# ------------------------------------------------------------------------- echo server


async def echo_app(scope, receive, send):
    """The floor: read the whole body, send it back (200, application/octet-stream)."""
    if scope["type"] == "lifespan":
        while True:
            message = await receive()
            if message["type"] == "lifespan.startup":
                await send({"type": "lifespan.startup.complete"})
            elif message["type"] == "lifespan.shutdown":
                await send({"type": "lifespan.shutdown.complete"})
                return
    chunks, more = [], True
    while more:
        message = await receive()
        chunks.append(message.get("body", b""))
        more = message.get("more_body", False)
    body = b"".join(chunks) or b"{}"
    await send({"type": "http.response.start", "status": 200,
                "headers": [(b"content-type", b"application/octet-stream"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


def serve_echo(port: int) -> None:
    """Run :func:`echo_app` on ``port`` (in a child process: ``python -c``)."""
    import uvicorn

    uvicorn.run(echo_app, host="127.0.0.1", port=port, log_level="warning", access_log=False,
                timeout_keep_alive=30)


# ------------------------------------------------------------------------- processes


def free_port() -> int:
    """A TCP port that was free on 127.0.0.1 a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def ready_process(args: list[str], port: int, ready_path: str):
    """``python *args`` in a child process, yielded once ``GET ready_path`` on ``port`` answers
    200 (60 s at most); terminated on exit."""
    from impactnet.service.client import ImpactClient

    proc = subprocess.Popen([sys.executable, *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        client = ImpactClient(f"http://127.0.0.1:{port}")
        deadline = time.monotonic() + 60
        while True:
            with contextlib.suppress(OSError):
                if client.request("GET", ready_path)[0] == 200:
                    break
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"server {args} did not start")
            time.sleep(0.05)
        client.close()
        yield
    finally:
        proc.terminate()
        proc.wait(30)


def percentiles(seconds: list[float]) -> dict:
    """Latency percentiles (ms) of ``seconds``."""
    ms = np.asarray(seconds) * 1e3
    return {"n": len(ms), "p50_ms": float(np.percentile(ms, 50)),
            "p90_ms": float(np.percentile(ms, 90)), "p99_ms": float(np.percentile(ms, 99)),
            "mean_ms": float(ms.mean()), "max_ms": float(ms.max())}


def latency(call, n: int, warmup: int) -> dict:
    """Percentiles (ms) of ``call()`` over ``n`` timed calls after ``warmup`` untimed ones."""
    for _ in range(warmup):
        call()
    times = []
    for _ in range(n):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return percentiles(times)


def timed(call, repeats: int) -> dict:
    """Median and min seconds of ``call()`` over ``repeats`` calls after one warm-up call."""
    call()  # warm-up (first-call costs, buffers)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return {"repeats": repeats, "median_s": float(np.median(times)), "min_s": float(min(times))}
