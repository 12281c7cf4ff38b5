"""Bounded load on loopback: 16 concurrent keep-alive clients for 20 s against a real server,
mixed single pairs and batches (JSON and npz): zero failed requests, one model version."""
from __future__ import annotations

import collections
import threading
import time

import numpy as np
import pytest

from service.client import ImpactClient
from tests.service.conftest import PAIR, ServerProcess
from tests.service.test_batch import poses

CLIENTS = 16
SECONDS = 20.0
KINDS = ["single", "single", "single", "batch_npz", "batch_json"]


@pytest.mark.slow
def test_sixteen_clients_twenty_seconds_no_failures():
    proc = ServerProcess(args=["--no-access-log"])
    try:
        proc.wait_ready()
        columns = poses(200, seed=7)
        versions: set[str] = set()
        counts: collections.Counter = collections.Counter()
        failures: list[str] = []
        lock = threading.Lock()
        stop = time.monotonic() + SECONDS

        def worker(k: int) -> None:
            rng = np.random.default_rng(k)
            with ImpactClient(proc.url, timeout=60) as client:
                while time.monotonic() < stop:
                    kind = str(rng.choice(KINDS))
                    try:
                        if kind == "single":
                            answer = client.contact(PAIR["a"], PAIR["b"])
                            version, ok = answer["model_version"], answer["colliding"]
                        else:
                            out = client.batch(columns, binary=(kind == "batch_npz"))
                            version, ok = out["model_version"], out["point"].shape == (200, 3)
                        with lock:
                            versions.add(version)
                            counts[kind] += 1
                            if not ok:
                                failures.append(f"{kind}: wrong answer")
                    except Exception as exc:  # noqa: BLE001 - every failure is counted
                        with lock:
                            failures.append(f"{kind}: {type(exc).__name__}: {exc}")

        threads = [threading.Thread(target=worker, args=(k,)) for k in range(CLIENTS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(SECONDS + 120)
        assert not failures, failures[:5]
        assert len(versions) == 1, versions
        assert counts["single"] > 100 and counts["batch_npz"] > 10 and counts["batch_json"] > 10
        print(f"\nload: {dict(counts)} in {SECONDS:.0f} s, version {versions.pop()}")
        assert proc.stop() == 0
    finally:
        proc.cleanup()
