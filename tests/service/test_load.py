"""Bounded load on loopback with an admin reload in the middle: 16 concurrent keep-alive
clients for 20 s against a real server serving the test bundle, mixed single pairs and
batches (JSON and npz) in every mode; halfway through, the bundle is reloaded. Zero failed
requests; every response carries one model version (header and body agree), the old or the
new one; a request sent after the reload answered gets only the new one."""
from __future__ import annotations

import collections
import threading
import time

import numpy as np
import orjson
import pytest

from impactnet.service.client import ImpactClient
from tests.service.conftest import ServerProcess
from tests.service.learned import write_bundle, write_scene
from tests.service.test_learned import ON_SLAB, _mixed

CLIENTS = 16
SECONDS = 20.0
KINDS = ["single", "single", "single", "batch_npz", "batch_json"]
MODES = [None, "exact", "single", "committee", "auto"]  # None: the server's default (auto)
TOKEN = "load-test-token"


@pytest.mark.slow
def test_sixteen_clients_twenty_seconds_with_a_reload(tmp_path):
    scene = write_scene(tmp_path / "scenes")
    old = write_bundle(tmp_path / "v1", scene, version="svc-load-old")
    new = write_bundle(tmp_path / "v2", scene, version="svc-load-new")
    proc = ServerProcess(args=["--no-access-log", "--scene", str(scene), "--bundle", str(old)],
                         env={"IMPACTNET_ADMIN_TOKEN": TOKEN})
    assert proc.url.startswith("http://127.0.0.1:")
    try:
        proc.wait_ready()
        columns = {k: np.asarray(v) for k, v in _mixed(200, seed=7).items()}
        seen: list[tuple[float, float, str]] = []  # (sent, answered, version) per response
        counts: collections.Counter = collections.Counter()
        failures: list[str] = []
        lock = threading.Lock()
        stop = time.monotonic() + SECONDS

        def one(client: ImpactClient, kind: str, mode: str | None) -> str:
            if kind == "single":
                body = ON_SLAB | ({"mode": mode} if mode else {})
                status, headers, data = client.request(
                    "POST", "/v2/contact", orjson.dumps(body),
                    {"Content-Type": "application/json"})
                answer = orjson.loads(data)
                assert status == 200, answer
                assert headers["x-model-version"] == answer["model_version"], "mixed"
                assert answer["colliding"] in (True, False)
                return answer["model_version"]
            out = client.batch(columns, mode=mode, binary=(kind == "batch_npz"))
            assert out["point"].shape == (200, 3) and np.isfinite(out["point"]).all()
            assert client.last_model_version == out["model_version"], "mixed"
            return out["model_version"]

        def worker(k: int) -> None:
            rng = np.random.default_rng(k)
            with ImpactClient(proc.url, timeout=60) as client:
                while time.monotonic() < stop:
                    kind, mode = str(rng.choice(KINDS)), MODES[rng.integers(len(MODES))]
                    sent = time.monotonic()
                    try:
                        version = one(client, kind, mode)
                    except Exception as exc:  # noqa: BLE001 - every failure is counted
                        with lock:
                            failures.append(f"{kind} {mode}: {type(exc).__name__}: {exc}")
                        continue
                    with lock:
                        seen.append((sent, time.monotonic(), version))
                        counts[kind] += 1

        threads = [threading.Thread(target=worker, args=(k,)) for k in range(CLIENTS)]
        for t in threads:
            t.start()
        time.sleep(SECONDS / 2)
        with ImpactClient(proc.url, timeout=60) as admin:
            reload_sent = time.monotonic()
            report = admin.reload(TOKEN, str(new))
            reload_done = time.monotonic()
        for t in threads:
            t.join(SECONDS + 120)

        assert not failures, failures[:5]
        assert report["model_version"] == "svc-load-new"
        assert report["previous_model_version"] == "svc-load-old"
        versions = collections.Counter(v for _, _, v in seen)
        assert set(versions) == {"svc-load-old", "svc-load-new"}, versions
        late = [v for sent, _, v in seen if sent > reload_done]
        early = [v for _, answered, v in seen if answered < reload_sent]
        assert late and set(late) == {"svc-load-new"}
        assert early and set(early) == {"svc-load-old"}
        assert counts["single"] > 100 and counts["batch_npz"] > 10 and counts["batch_json"] > 10
        print(f"\nload: {dict(counts)} in {SECONDS:.0f} s, versions {dict(versions)}, "
              f"reload {reload_done - reload_sent:.3f} s")
        assert proc.stop() == 0
    finally:
        proc.cleanup()
