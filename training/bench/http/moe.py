"""`impactnet bench moe --http`: issue #21's HTTP goals on the detailed scene, on loopback.

A server (``python -m impactnet.service``) is started on a free loopback port with the detailed
scene and its bundle (:func:`impactnet.training.bench.http.predictors.running_server`); with one
keep-alive client (the simulator's, :class:`impactnet.service.client.ImpactClient`), in one run:

* the floor: ``GET /healthz`` latency percentiles;
* ``POST /v2/contact``: a spreader on a 40 ft container (the pair's held-out poses in turn),
  mode ``auto`` and mode ``exact``: latency percentiles, and p50 over the floor's p50
  (goal: <= 2.5x in mode auto);
* ``POST /v2/contact/batch`` as npz: ``batch_poses`` spreader poses end to end, mode ``auto``
  and mode ``exact`` (goal: auto >= 2.5x faster).

Where the bundle records a pair exact-only, ``auto`` is the oracle; a second server then serves
a copy of the bundle with every pair's decision lifted (:func:`lifted_copy`), and the same
``auto`` measurements are taken there: what the learned path would give over HTTP.
"""
from __future__ import annotations

import itertools
import time

import numpy as np

from impactnet.training.bench.http.loopback import latency
from impactnet.training.bench.http.predictors import running_server

#: The goals of issue #21 over HTTP.
CONTACT_OVER_FLOOR_MAX, BATCH_SPEEDUP_MIN = 2.5, 2.5
IDENTITY = [1.0, 0.0, 0.0, 0.0]
#: Seconds the client waits for a batch answer (the oracle: ~1.5 ms per spreader pose).
BATCH_TIMEOUT_S = 1200.0


def lifted_copy(bundle, folder) -> str:
    """A copy of ``bundle`` (folder or store) in ``folder`` whose compound pairs are all
    recorded learned (models and figures unchanged): to measure the learned path served."""
    import copy

    from impactnet.models.bundle.store import resolve_bundle
    from impactnet.models.learned.bundle_loader import read_bundle, write_bundle

    source = read_bundle(resolve_bundle(bundle))
    manifest = copy.deepcopy(source.manifest)
    manifest.pop("files", None)
    for entry in manifest.get("compound_pairs", {}).values():
        if entry.get("groups") and all("labels" in g for g in entry["groups"]):
            entry["decision"]["serve"] = "learned"
    tensors = {}
    for name, mlp in source.mlps.items():
        tensors |= mlp.to_tensors(name)
    return str(write_bundle(folder, manifest, tensors))


def measure_http(scene: str, bundle: str | None, position: np.ndarray, quaternion: np.ndarray,
                 requests: int, batch_poses: int, log=print) -> dict:
    """The figures of the module docstring; ``position`` (k, 3), ``quaternion`` (k, 4): B's
    (the spreader's) poses with the container at the origin."""
    import tempfile

    from impactnet.models.predictors import DEFAULT_BUNDLE

    out = _measure_server(scene, bundle, position, quaternion, requests, batch_poses,
                          ("auto", "exact"), log)
    if set(out["batch_auto"]["answered_by"]) == {"oracle"}:  # recorded exact-only: lift it
        with tempfile.TemporaryDirectory() as folder:
            lifted = lifted_copy(bundle or DEFAULT_BUNDLE.parent / "quay_crane_detail",
                                 f"{folder}/lifted")
            more = _measure_server(scene, lifted, position, quaternion, requests, batch_poses,
                                   ("auto",), log)
        out["lifted"] = {"floor": more["floor"], "contact_auto": more["contact_auto"],
                         "batch_auto": more["batch_auto"],
                         "contact_auto_over_floor": more["contact_auto"]["p50_ms"]
                         / more["floor"]["p50_ms"],
                         "batch_speedup": out["batch_exact"]["seconds"]
                         / more["batch_auto"]["seconds"]}
    floor = out["floor"]["p50_ms"]
    out["contact_auto_over_floor"] = out["contact_auto"]["p50_ms"] / floor
    out["contact_exact_over_floor"] = out["contact_exact"]["p50_ms"] / floor
    out["batch_speedup"] = out["batch_exact"]["seconds"] / out["batch_auto"]["seconds"]
    out["goals"] = {"contact_auto_over_floor": out["contact_auto_over_floor"]
                    <= CONTACT_OVER_FLOOR_MAX,
                    "batch_speedup": out["batch_speedup"] >= BATCH_SPEEDUP_MIN}
    return out


def _measure_server(scene: str, bundle, position, quaternion, requests: int,
                    batch_poses: int, modes: tuple[str, ...], log) -> dict:
    """Floor, single pairs and the npz batch in ``modes`` through one server."""
    out = {}
    with running_server(scene, bundle, log) as (client, info):
        out["server"] = info
        out["floor"] = latency(lambda: client.request("GET", "/healthz"), requests, 20)
        for mode in modes:
            def one(mode=mode, calls=itertools.count()):  # the poses in turn
                i = next(calls) % len(position)
                client.contact({"object": "container40", "position": [0, 0, 0],
                                "quaternion": IDENTITY},
                               {"object": "spreader", "position": position[i].tolist(),
                                "quaternion": quaternion[i].tolist()}, mode=mode)
            out[f"contact_{mode}"] = latency(one, requests, 20)
        take = np.resize(np.arange(len(position)), batch_poses)
        columns = {"a_object": np.array("container40"), "a_position": np.zeros(3),
                   "a_quaternion": np.array(IDENTITY), "b_object": np.array("spreader"),
                   "b_position": position[take], "b_quaternion": quaternion[take]}
        client.close()
        client.timeout = BATCH_TIMEOUT_S  # the oracle takes minutes on 100,000 spreader poses
        for mode in modes:
            start = time.perf_counter()
            answer = client.batch(columns, mode=mode)
            out[f"batch_{mode}"] = {"poses": batch_poses, "seconds": time.perf_counter() - start,
                                    "answered_by": {str(p): int((answer["predictor"] == p).sum())
                                                    for p in np.unique(answer["predictor"])}}
    return out


def http_lines(http: dict) -> list[str]:
    """The HTTP section of the report."""
    f, ca, ce = http["floor"], http["contact_auto"], http["contact_exact"]
    ba, be = http["batch_auto"], http["batch_exact"]
    return ["", "## Over HTTP (detailed scene, spreader on a 40 ft container, loopback)", "",
            "| measurement | p50 | p99 | over the /healthz floor (p50) |", "|---|---|---|---|",
            f"| GET /healthz (floor) | {f['p50_ms']:.2f} ms | {f['p99_ms']:.2f} ms | 1x |",
            f"| POST /v2/contact, auto | {ca['p50_ms']:.2f} ms | {ca['p99_ms']:.2f} ms | "
            f"{http['contact_auto_over_floor']:.1f}x (goal <= {CONTACT_OVER_FLOOR_MAX}x) |",
            f"| POST /v2/contact, exact | {ce['p50_ms']:.2f} ms | {ce['p99_ms']:.2f} ms | "
            f"{http['contact_exact_over_floor']:.1f}x |", "",
            f"npz batch of {ba['poses']:,} spreader poses, end to end: auto "
            f"{ba['seconds']:.1f} s ({ba['answered_by']}), exact {be['seconds']:.1f} s: auto "
            f"is {http['batch_speedup']:.2f}x faster (goal >= {BATCH_SPEEDUP_MIN}x)."] + (
                _lifted_lines(http["lifted"]) if http.get("lifted") else [])


def _lifted_lines(lifted: dict) -> list[str]:
    c, b = lifted["contact_auto"], lifted["batch_auto"]
    return ["", "The bundle records the pair exact-only, so `auto` above is the oracle. With "
            "the decisions lifted (the learned path served, a second server in the same run): "
            f"`/v2/contact` p50 {c['p50_ms']:.2f} ms, {lifted['contact_auto_over_floor']:.1f}x "
            f"its floor ({lifted['floor']['p50_ms']:.2f} ms); the npz batch {b['seconds']:.1f} s "
            f"({b['answered_by']}), {lifted['batch_speedup']:.2f}x faster than exact."]
