"""HTTP benchmark of the service on loopback (a script, not a test).

    python -m impactnet.training.bench.http.service_speed [--quick] [--json PATH] [--access-log]
        [--mode M] [--bundle PATH] [--url URL] [--clients N]

(Formerly ``python -m impactnet.service.bench_http``: a benchmark client, never imported by the
service; the loopback plumbing it shares with the other HTTP benchmarks is
:mod:`impactnet.training.bench.http.loopback`.)

One uvicorn worker per server process, started here on free loopback ports; one keep-alive
client (:class:`impactnet.service.client.ImpactClient`, the simulator's client) issues requests one
after another. Measured in the same run:

* floor: a bare ASGI echo app on the same uvicorn (same event loop and HTTP parser, no
  FastAPI, no middleware) answering the same requests: what HTTP on loopback costs by itself;
* ``POST /v2/contact``: latency percentiles over single pairs;
* ``POST /v2/contact/batch`` with 100,000 pairs end to end (client encoding, transfer, server
  validation + exact solver + encoding, client decoding to NumPy arrays) as JSON and as npz,
  beside the echo of the same request bytes and the exact solver alone in this process.

Goals (issue 5): contact p50 <= 1 ms, p99 <= 3 ms; 100k batch <= 2 s JSON, <= 0.2 s binary.
``--mode`` is the server's default mode for these requests (``exact`` unless given, so the
figures stay comparable whether or not a bundle is loaded); ``--bundle`` as ``impactnet
serve`` (default: the scene's shipped bundle when it exists).

``--url`` measures a service that is already running there (a fleet's front: docs/fleet.md)
instead of starting one; ``--mode`` is then sent with each request. ``--clients N`` adds a
throughput section: N client processes, each with its own keep-alive connection, send single
pairs (req/s, pooled p50 / p99) and then 100,000-pair npz batches (pairs/s) at once.
"""
from __future__ import annotations

import argparse
import contextlib
import http.client
import io
import json
import multiprocessing
import os
import platform
import time

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import numpy as np  # noqa: E402 - after pinning the BLAS thread count

from impactnet.service.client import ImpactClient  # noqa: E402
from impactnet.training.bench.http.loopback import (  # noqa: E402
    free_port,
    latency,
    percentiles,
    ready_process,
    timed,
)

PAIR = {"a": {"object": "cube", "position": [0.0, 0.0, 0.0], "quaternion": [1.0, 0, 0, 0]},
        "b": {"object": "cube", "position": [0.5, 0.3, 1.95], "euler": [0.05, 0.0, 0.0]}}


# ------------------------------------------------------------------------- measurements


def poses(n: int, seed: int = 0) -> dict:
    """N cube pairs around contact (about half touching), as batch columns."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(2, n, 4))
    q /= np.linalg.norm(q, axis=2, keepdims=True)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return {"a_size": np.full((n, 3), 2.0), "a_position": np.zeros((n, 3)), "a_quaternion": q[0],
            "b_size": np.full((n, 3), 2.0),
            "b_position": direction * rng.uniform(1.9, 3.0, size=(n, 1)), "b_quaternion": q[1]}


# ------------------------------------------------------------------------- throughput


def _npz(columns: dict) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    return buffer.getvalue()


def _client_worker(url: str, kind: str, count: int, warmup: int, mode: str, barrier,
                   results) -> None:
    """One client process: ``warmup`` then ``count`` requests of ``kind`` (``pair`` or
    ``npz``) after every client is ready; puts (latencies s, start, end, failures)."""
    api = ImpactClient(url, retries=0)
    if kind == "pair":
        body = json.dumps({**PAIR, "mode": mode}).encode()
        headers, path = {"Content-Type": "application/json"}, "/v2/contact"
    else:
        body, headers = _npz(poses(100_000)), {"Content-Type": "application/x-npz",
                                               "Accept": "application/x-npz"}
        path = f"/v2/contact/batch?mode={mode}"
    for _ in range(warmup):
        api.request("POST", path, body, headers)
    barrier.wait()
    times, failures, start = [], 0, time.perf_counter()
    for _ in range(count):
        sent = time.perf_counter()
        try:
            status = api.request("POST", path, body, headers)[0]
        except (OSError, http.client.HTTPException):
            status = 0
        times.append(time.perf_counter() - sent)
        failures += status != 200
    results.put((times, start, time.perf_counter(), failures))
    api.close()


def throughput(url: str, clients: int, kind: str, count: int, warmup: int,
               mode: str = "exact") -> dict:
    """``clients`` processes sending ``count`` requests each at once (:func:`_client_worker`):
    requests per second over the wall time of all, latency percentiles over all requests."""
    context = multiprocessing.get_context("fork")
    barrier, results = context.Barrier(clients), context.Queue()
    workers = [context.Process(target=_client_worker, args=(url, kind, count, warmup, mode,
                                                            barrier, results))
               for _ in range(clients)]
    for worker in workers:
        worker.start()
    done = [results.get(timeout=600) for _ in workers]
    for worker in workers:
        worker.join(60)
    times = [t for d in done for t in d[0]]
    wall = max(d[2] for d in done) - min(d[1] for d in done)
    out = {"clients": clients, "requests": len(times), "wall_s": wall,
           "req_per_s": len(times) / wall, "failures": sum(d[3] for d in done),
           **percentiles(times)}
    if kind == "npz":
        out["pairs_per_s"] = out["req_per_s"] * 100_000
    return out


def run(quick: bool = False, json_path: str | None = None, access_log: bool = False,
        mode: str = "exact", bundle: str | None = None, url: str | None = None,
        clients: int = 0) -> int:
    n_single, warmup = (500, 100) if quick else (5000, 500)
    repeats = 2 if quick else 5
    n_batch = 100_000
    echo_port, service_port = free_port(), free_port()
    service_args = ["-m", "impactnet.service", "--port", str(service_port), "--default-mode", mode]
    if bundle is not None:
        service_args += ["--bundle", bundle]
    if not access_log:  # access lines are info: with them on, keep the info level
        service_args += ["--no-access-log", "--log-level", "warning"]
    columns = poses(n_batch)
    single_body = json.dumps(PAIR).encode()
    machine = {"python": platform.python_version(), "cpus": os.cpu_count(),
               "platform": platform.platform(), "load_avg_1m": os.getloadavg()[0]}
    results: dict = {"access_log": access_log, "mode": mode, "machine": machine, "url": url}

    from impactnet.models.box.exact import box_box

    results["solver_only_100k"] = timed(lambda: box_box(*(columns[k] for k in (
        "a_size", "a_position", "a_quaternion", "b_size", "b_position", "b_quaternion"))),
        repeats)

    service = (contextlib.nullcontext() if url
               else ready_process(service_args, service_port, "/readyz"))
    url = url or f"http://127.0.0.1:{service_port}"
    if results["url"]:  # a running service: its default mode may differ, name it
        single_body = json.dumps({**PAIR, "mode": mode}).encode()
    with ready_process(["-c", f"from impactnet.training.bench.http.loopback import serve_echo; "
                         f"serve_echo({echo_port})"],
                  echo_port, "/"), service:
        echo = ImpactClient(f"http://127.0.0.1:{echo_port}")
        api = ImpactClient(url)
        headers = {"Content-Type": "application/json"}
        results["echo_single"] = latency(
            lambda: echo.request("POST", "/", single_body, headers), n_single, warmup)
        results["contact"] = latency(
            lambda: api.request("POST", "/v2/contact", single_body, headers), n_single, warmup)
        results["contact_client"] = latency(lambda: api.contact(PAIR["a"], PAIR["b"]),
                                              n_single, warmup)
        results["healthz"] = latency(lambda: api.request("GET", "/healthz"), n_single, warmup)

        import orjson

        json_bytes = orjson.dumps(columns, option=orjson.OPT_SERIALIZE_NUMPY)
        npz_bytes = _npz(columns)
        results["batch_sizes_bytes"] = {"json_request": len(json_bytes),
                                        "npz_request": len(npz_bytes)}
        results["echo_batch_json"] = timed(
            lambda: echo.request("POST", "/", json_bytes, headers), repeats)
        results["echo_batch_npz"] = timed(
            lambda: echo.request("POST", "/", npz_bytes, {"Content-Type": "application/x-npz"}),
            repeats)
        results["batch_json"] = timed(lambda: api.batch(columns, binary=False, mode=mode),
                                       repeats)
        results["batch_npz"] = timed(lambda: api.batch(columns, binary=True, mode=mode),
                                      repeats)
        echo.close()
        api.close()
        if clients:
            results["throughput_pairs"] = throughput(url, clients, "pair", n_single // 2,
                                                     warmup // 5, mode)
            results["throughput_npz"] = throughput(url, clients, "npz", repeats, 1, mode)

    _report(results, n_batch)
    if json_path:
        with open(json_path, "w") as f:
            json.dump(results, f, indent=2)
    return 0


def _report(r: dict, n_batch: int) -> None:
    m = r["machine"]
    print(f"impactnet HTTP bench: Python {m['python']}, {m['cpus']} CPUs, load avg "
          f"{m['load_avg_1m']:.2f} (a shared machine: figures vary with its load); server "
          f"access log {'on' if r['access_log'] else 'off'}; mode {r['mode']}\n")
    print("| request (one keep-alive client, loopback) | p50 ms | p90 ms | p99 ms | mean ms |")
    print("|---|---|---|---|---|")
    for key, label in (("echo_single", "floor: bare uvicorn echo, same body"),
                       ("healthz", "GET /healthz"),
                       ("contact", "POST /v2/contact (raw request)"),
                       ("contact_client", "POST /v2/contact (ImpactClient.contact)")):
        s = r[key]
        print(f"| {label} | {s['p50_ms']:.3f} | {s['p90_ms']:.3f} | {s['p99_ms']:.3f} | "
              f"{s['mean_ms']:.3f} |")
    print(f"\n| {n_batch:,} pairs, end to end | median s | min s |")
    print("|---|---|---|")
    for key, label in (("solver_only_100k", "exact solver alone, in process"),
                       ("echo_batch_json", "floor: echo of the JSON request "
                        f"({r['batch_sizes_bytes']['json_request'] / 1e6:.1f} MB)"),
                       ("batch_json", "batch as JSON (ImpactClient.batch binary=False)"),
                       ("echo_batch_npz", "floor: echo of the npz request "
                        f"({r['batch_sizes_bytes']['npz_request'] / 1e6:.1f} MB)"),
                       ("batch_npz", "batch as npz (ImpactClient.batch binary=True)")):
        s = r[key]
        print(f"| {label} | {s['median_s']:.3f} | {s['min_s']:.3f} |")
    if "throughput_pairs" in r:
        p, b = r["throughput_pairs"], r["throughput_npz"]
        print(f"\n| {p['clients']} clients at once ({r['url'] or 'one server'}) | req/s | "
              "pairs/s | p50 ms | p99 ms | failed |")
        print("|---|---|---|---|---|---|")
        print(f"| POST /v2/contact, {p['requests']} requests | {p['req_per_s']:.0f} | "
              f"{p['req_per_s']:.0f} | {p['p50_ms']:.3f} | {p['p99_ms']:.3f} | "
              f"{p['failures']} |")
        print(f"| npz batches of {n_batch:,}, {b['requests']} requests | {b['req_per_s']:.2f} | "
              f"{b['pairs_per_s']:.0f} | {b['p50_ms']:.0f} | {b['p99_ms']:.0f} | "
              f"{b['failures']} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.training.bench.http.service_speed",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer requests (a smoke run)")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    parser.add_argument("--access-log", action="store_true",
                        help="keep the server's JSON access log on (to /dev/null)")
    parser.add_argument("--mode", default="exact", choices=["exact", "single", "committee",
                                                              "auto"],
                        help="mode of the requests (the server's default mode; default exact)")
    parser.add_argument("--bundle", help="the server's --bundle (default: the shipped one)")
    parser.add_argument("--url", help="measure the service running there (e.g. a fleet's "
                        "front) instead of starting one")
    parser.add_argument("--clients", type=int, default=0,
                        help="also measure throughput with N concurrent client processes")
    args = parser.parse_args(argv)
    return run(quick=args.quick, json_path=args.json, access_log=args.access_log,
               mode=args.mode, bundle=args.bundle, url=args.url, clients=args.clients)


if __name__ == "__main__":
    raise SystemExit(main())
