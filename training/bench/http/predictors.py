"""`impactnet bench --http`: the same predictors through the HTTP service, on loopback.

A server (``python -m impactnet.service``, the command behind ``impactnet serve``) is started here
on 127.0.0.1 at a free port, with the benchmark's scene (and ``--bundle`` when one is given), its
access log off; the benchmark waits (bounded) for ``/readyz``, reads the modes it serves from
``/v1/models``, and per mode measures with :class:`impactnet.service.client.ImpactClient` (one
keep-alive connection, the simulator's client):

* ``POST /v2/contact``: one pair per request (bodies named by the scene's objects), warm-up
  first, median and p99 of the request time over a fixed number of scene poses;
* ``POST /v2/contact/batch`` as npz: the scene set (up to the server's ``max_batch_pairs``),
  one warm-up call (scored), then the median of the timed calls.

Errors are computed against the in-process exact solver on the same poses. Modes the server
does not serve are reported with the server's reason. The server is stopped with SIGTERM (its
graceful shutdown) and waited for; it is killed only if it has not exited in time.
"""
from __future__ import annotations

import contextlib
import signal
import statistics
import subprocess
import sys
import time

import numpy as np

from impactnet.training.bench.accuracy import errors as er
from impactnet.training.bench.http.loopback import free_port
from impactnet.training.bench.methods import Answer

#: Seconds to wait for the server's /readyz, and for its exit after SIGTERM.
START_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 30.0
#: Seconds between readiness polls.
POLL_S = 0.05
#: Untimed /v2/contact requests per mode before timing.
CONTACT_WARMUP = 50


@contextlib.contextmanager
def running_server(scene: str, bundle: str | None, log):
    """Start ``python -m impactnet.service`` on a free loopback port; yields (client, info)."""
    from impactnet.service.client import ImpactClient

    port = free_port()
    command = [sys.executable, "-m", "impactnet.service", "--host", "127.0.0.1",
               "--port", str(port),
               "--scene", scene, "--no-access-log", "--log-level", "warning"]
    if bundle:
        command += ["--bundle", bundle]
    t0 = time.perf_counter()
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    client = ImpactClient(f"http://127.0.0.1:{port}", retries=0)
    info = {"port": port, "command": " ".join(command[1:])}
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while not _ready(client):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the server did not become ready (exit code "
                                   f"{proc.poll()}): {_stderr(proc)}")
            time.sleep(POLL_S)
        info["start_s"] = round(time.perf_counter() - t0, 2)
        log(f"bench --http: server ready on 127.0.0.1:{port} in {info['start_s']} s")
        yield client, info
    finally:
        client.close()
        info.update(_stop(proc))


def _ready(client) -> bool:
    with contextlib.suppress(OSError):
        return client.request("GET", "/readyz")[0] == 200
    return False


def _stderr(proc) -> str:
    if proc.poll() is None or proc.stderr is None:
        return ""
    return proc.stderr.read().decode("utf-8", "replace")[-500:]


def _stop(proc) -> dict:
    """SIGTERM, wait; kill only after STOP_TIMEOUT_S."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            return {"exit_code": proc.returncode, "stopped_gracefully": False}
    if proc.stderr is not None:
        proc.stderr.close()
    return {"exit_code": proc.returncode, "stopped_gracefully": proc.returncode == 0}


def _objects(poses) -> tuple[np.ndarray, np.ndarray]:
    names = np.array(poses.pair_names)  # (pairs, 2)
    return names[poses.pair, 0], names[poses.pair, 1]


def _contact(client, poses, reference, mode: str, count: int) -> dict:
    """Per-request times and errors of /v2/contact over ``count`` scene poses."""
    rows = poses.subsample(count + CONTACT_WARMUP)
    a_names, b_names = _objects(poses)
    times, colliding, point, normal = [], [], [], []
    for k, i in enumerate(rows):
        a = {"object": str(a_names[i]), "position": poses.position_a[i].tolist(),
             "quaternion": poses.quaternion_a[i].tolist()}
        b = {"object": str(b_names[i]), "position": poses.position_b[i].tolist(),
             "quaternion": poses.quaternion_b[i].tolist()}
        t0 = time.perf_counter()
        answer = client.contact(a, b, mode=mode)
        elapsed = time.perf_counter() - t0
        if k >= CONTACT_WARMUP:
            times.append(elapsed)
        colliding.append(answer["colliding"])
        point.append(answer["point"])
        normal.append(answer["normal"])
    scored = Answer(np.array(colliding), np.array(point, float), np.array(normal, float))
    summary = er.method_summary(er.row_errors(scored, reference.take(rows), poses.scale[rows]))
    return {"requests": len(times), "us_median": 1e6 * statistics.median(times),
            "us_p99": 1e6 * float(np.percentile(times, 99)), "errors": summary.to_dict()}


def _batch(client, poses, reference, mode: str, limit: int, repeats: int) -> dict:
    """Median time and errors of /v2/contact/batch (npz) over the scene set (up to limit)."""
    rows = np.arange(min(len(poses), limit))
    a_names, b_names = _objects(poses)
    columns = {"a_object": a_names[rows], "a_position": poses.position_a[rows],
               "a_quaternion": poses.quaternion_a[rows], "b_object": b_names[rows],
               "b_position": poses.position_b[rows], "b_quaternion": poses.quaternion_b[rows]}
    out = client.batch(columns, mode=mode, binary=True)  # warm-up, scored
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        client.batch(columns, mode=mode, binary=True)
        times.append(time.perf_counter() - t0)
    seconds = statistics.median(times)
    scored = Answer(np.asarray(out["colliding"], bool), np.asarray(out["point"], float),
                    np.asarray(out["normal"], float))
    summary = er.method_summary(er.row_errors(scored, reference.take(rows), poses.scale[rows]))
    return {"n": len(rows), "repeats": repeats, "seconds_median": seconds,
            "pairs_per_s": len(rows) / seconds, "us_per_pair": 1e6 * seconds / len(rows),
            "errors": summary.to_dict()}


def measure_http(config, poses, scene, log) -> dict:
    """Every mode (exact and the learned ones) through the service; see the module docstring."""
    from impactnet.models.box.exact import box_box

    reference = Answer.from_contacts(box_box(*poses.args()))
    modes = ("exact", *config.learned)
    results = {"pose_set": poses.name, "modes": {}}
    try:
        with running_server(config.scene, config.bundle, log) as (client, info):
            served = client.models()
            unavailable = served["modes"]["unavailable"]
            limit = int(served["limits"]["max_batch_pairs"])
            for mode in modes:
                if mode in unavailable or mode not in served["modes"]["available"]:
                    reason = unavailable.get(mode, "not served")
                    results["modes"][mode] = {"status": f"not available: {reason}"}
                    continue
                results["modes"][mode] = {
                    "status": "ok",
                    "contact": _contact(client, poses, reference, mode, config.http_requests),
                    "batch": _batch(client, poses, reference, mode, limit,
                                    config.http_batch_repeats)}
                log(f"  http {mode}: done")
        results["server"] = info
    except Exception as exc:  # noqa: BLE001 - the HTTP columns fail alone, with the reason
        results["error"] = f"{type(exc).__name__}: {exc}"
    return results


def http_table(http: dict) -> str:
    """Markdown lines of the HTTP measurement."""
    if "error" in http:
        return f"HTTP measurement failed: {http['error']}"
    lines = ["| mode | /v2/contact µs median / p99 | requests | batch (npz) N | pairs/s "
             "| µs/pair | normal error ° p99 (contact, batch) | point error % p99 "
             "(contact, batch) |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for mode, m in http["modes"].items():
        if m["status"] != "ok":
            lines.append(f"| {mode} | {m['status']} |" + " – |" * 6)
            continue
        c, b = m["contact"], m["batch"]
        lines.append(
            f"| {mode} | {c['us_median']:.0f} / {c['us_p99']:.0f} | {c['requests']:,} | "
            f"{b['n']:,} | {b['pairs_per_s']:,.0f} | {b['us_per_pair']:.3g} | "
            f"{_g(c['errors']['normal_deg_p99'])}, {_g(b['errors']['normal_deg_p99'])} | "
            f"{_g(c['errors']['point_pct_p99'])}, {_g(b['errors']['point_pct_p99'])} |")
    server = http.get("server", {})
    lines += ["", f"Server: `{server.get('command')}`, ready in {server.get('start_s')} s; "
              f"stopped with SIGTERM, exit code {server.get('exit_code')} "
              f"({'graceful' if server.get('stopped_gracefully') else 'NOT graceful'})."]
    return "\n".join(lines)


def _g(x) -> str:
    return "–" if x is None else "0" if x == 0 else f"{x:.3g}"
