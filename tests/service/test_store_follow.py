"""Replicas follow a bundle store (impactnet.service.store_follow): a published version is
served within a poll, a broken one keeps the old one serving and is retried with back-off,
/v1/models and /metrics report the follow, every answer names its replica, shutdown stops the
follower."""
from __future__ import annotations

import asyncio
import http.client
import json
import re
import socket
import threading
import time

import pytest
from fastapi.testclient import TestClient

from impactnet.models.bundle.store import VERSIONS, set_current
from impactnet.service.app import create_app
from impactnet.service.store_follow import BACKOFF_FACTOR, BACKOFF_MAX_S, StoreFollower, backoff_s
from tests.service.conftest import PAIR, ServerProcess, test_settings
from tests.service.learned import corrupt, write_bundle, write_scene
from tests.service.test_learned import ON_SLAB

#: Seconds between polls in these tests: short, so that a follow is seen at once.
POLL_S = 0.05
#: Seconds a test waits for a follow before it fails: a poll, a load (read, smoke test with
#: 8 poses per pair, warm-up; ~0.1 s here) and a loaded 2-core machine's slack.
FOLLOW_WAIT_S = 4.0
#: Smoke-test poses per pair (the least allowed): the tests are about following, not accuracy.
SMOKE_POSES = 8
TOKEN = "test-admin-token"


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return write_scene(tmp_path_factory.mktemp("follow") / "scenes")


@pytest.fixture
def store(scene, tmp_path):
    """A store whose `current` is svc-v1 (folder names are the manifests' versions)."""
    folder = tmp_path / "store"
    write_bundle(folder / VERSIONS / "svc-v1", scene, version="svc-v1")
    set_current(folder, "svc-v1")
    return folder


def publish(store, scene, version: str, broken: bool = False) -> None:
    """Write ``version`` completely, then move `current` to it (what `impactnet train` does);
    ``broken``: one flipped byte in its weights, so its checksum fails."""
    folder = write_bundle(store / VERSIONS / version, scene, version=version)
    if broken:
        corrupt(folder)
    set_current(store, version)


def follower_app(scene, store, **overrides) -> TestClient:
    base = {"store_poll_s": POLL_S, "smoke_poses": SMOKE_POSES}
    settings = test_settings(scene=str(scene), bundle=str(store), **(base | overrides))
    return TestClient(create_app(settings), raise_server_exceptions=False)


def wait_for(predicate, timeout: float = FOLLOW_WAIT_S):
    """Poll ``predicate()`` until it returns something truthy; returns it (fails on timeout)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = predicate()
        if found:
            return found
        time.sleep(0.01)
    pytest.fail(f"not within {timeout} s")


def served(client) -> str:
    """The version that answers a contact, after checking that header and body agree."""
    response = client.post("/v2/contact", json=ON_SLAB | {"mode": "committee"})
    assert response.status_code == 200, response.text
    assert response.headers["x-model-version"] == response.json()["model_version"]
    return response.json()["model_version"]


def metric(text: str, series: str) -> float:
    match = re.search(re.escape(series) + r" ([0-9.e+]+)", text)
    return float(match.group(1)) if match else 0.0


# ----------------------------------------------------------------------------- following


def test_a_published_version_is_served_within_a_poll(scene, store):
    with follower_app(scene, store) as client:
        assert served(client) == "svc-v1"
        status = client.get("/v1/models").json()["store"]
        assert status["name"] == store.name and status["poll_s"] == POLL_S
        assert "path" not in status  # no server path to unauthenticated clients
        assert status["served"] == "svc-v1" and status["failures"] == 0
        started = time.monotonic()
        publish(store, scene, "svc-v2")
        wait_for(lambda: served(client) == "svc-v2")
        assert time.monotonic() - started < FOLLOW_WAIT_S
        body = client.get("/v1/models").json()
        assert body["model_version"] == "svc-v2" and body["bundle"]["store_version"] == "svc-v2"
        status = body["store"]
        assert status["current"] == status["served"] == "svc-v2" and status["in_sync"]
        last = status["last_follow"]
        assert last["result"] == "ok" and last["version"] == "svc-v2" and last["error"] is None
        text = client.get("/metrics").text
        assert metric(text, "impactnet_store_follows_total") == 1
        assert 'impactnet_store_info{current="svc-v2",served="svc-v2"} 1.0' in text
        assert 'impactnet_model_info{model_version="svc-v2"' in text
        assert 'model_version="svc-v1"' not in text
        assert "impactnet_bundle_reloads_total{" not in text  # follows are not admin reloads


def test_every_request_carries_one_version_while_the_fleet_switches(scene, store):
    """Requests race the follows: header, body and every batch row name one version."""
    batch = {"a_object": "brick", "a_position": [ON_SLAB["a"]["position"]] * 3,
             "a_quaternion": [1, 0, 0, 0], "b_object": "slab", "b_position": [0, 0, 0],
             "b_quaternion": [1, 0, 0, 0], "mode": "committee"}
    with follower_app(scene, store) as client:
        seen = set()
        for version in ("svc-v2", "svc-v3"):
            publish(store, scene, version)
            deadline = time.monotonic() + FOLLOW_WAIT_S
            while version not in seen and time.monotonic() < deadline:
                seen.add(served(client))
                response = client.post("/v2/contact/batch", json=batch)
                assert response.status_code == 200, response.text
                answer = response.json()
                assert answer["model_version"] == response.headers["x-model-version"]
                assert set(answer["predictor"]) == {"committee"}
        assert {"svc-v2", "svc-v3"} <= seen


def test_a_broken_version_keeps_the_old_one_serving_then_a_fix_is_followed(scene, store):
    with follower_app(scene, store) as client:
        publish(store, scene, "svc-bad", broken=True)
        status = wait_for(lambda: (s := client.get("/v1/models").json()["store"])["failures"]
                          and s)
        assert served(client) == "svc-v1"
        assert client.get("/readyz").status_code == 200
        last = status["last_follow"]
        assert status["current"] == "svc-bad" and status["served"] == "svc-v1"
        assert not status["in_sync"] and status["failing_version"] == "svc-bad"
        assert last["result"] == "failed" and last["step"] == "read"
        assert "sha-256" in last["error"].lower() and status["retry_at"] > time.time() - 1
        text = client.get("/metrics").text
        assert metric(text, 'impactnet_store_follow_failures_total{step="read"}') >= 1
        assert 'impactnet_store_info{current="svc-bad",served="svc-v1"} 1.0' in text
        publish(store, scene, "svc-v3")  # a fix is tried at the next poll, not after back-off
        wait_for(lambda: served(client) == "svc-v3")
        status = client.get("/v1/models").json()["store"]
        assert status["in_sync"] and status["failures"] == 0 and status["retry_at"] is None


def test_a_bad_pointer_is_a_failure_and_a_rollback_heals_it(scene, store):
    with follower_app(scene, store) as client:
        (store / "current").write_text("../escape\n")  # a hand edit gone wrong
        status = wait_for(lambda: (s := client.get("/v1/models").json()["store"])["failures"]
                          and s)
        assert status["last_follow"]["step"] == "resolve" and served(client) == "svc-v1"
        text = client.get("/metrics").text
        assert metric(text, 'impactnet_store_follow_failures_total{step="resolve"}') >= 1
        set_current(store, "svc-v1")  # the rollback
        wait_for(lambda: client.get("/v1/models").json()["store"]["failures"] == 0)
        assert client.get("/v1/models").json()["store"]["in_sync"]


def test_retries_of_a_broken_version_back_off(scene, store):
    """Over 1.2 s, 24 polls: without back-off 24 loads; with it (0.1, 0.2, 0.4 s ...) <= 4."""
    with follower_app(scene, store) as client:
        publish(store, scene, "svc-bad", broken=True)
        time.sleep(1.2)
        failures = client.get("/v1/models").json()["store"]["failures"]
        assert 1 <= failures <= 4, failures
        assert served(client) == "svc-v1"


def test_back_off_doubles_per_failure_up_to_its_cap():
    assert backoff_s(10.0, 1) == 10.0 * BACKOFF_FACTOR
    assert backoff_s(10.0, 2) == 10.0 * BACKOFF_FACTOR ** 2
    assert backoff_s(10.0, 30) == BACKOFF_MAX_S


class FakeClock:
    """Monotonic seconds that a test moves by hand."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_a_failing_version_is_retried_only_after_its_back_off(scene, store):
    """Polls driven by hand with a fake clock: the loads that each poll starts are counted."""
    with follower_app(scene, store, store_poll_s=0) as client:  # no follower of its own
        runtime, reloader = client.app.state.runtime, client.app.state.reloader
        assert runtime.follower is None and client.get("/v1/models").json()["store"] is None
        clock, loads = FakeClock(), []
        real = reloader.reload
        reloader.reload = lambda *a, **k: (loads.append(clock.now), real(*a, **k))[1]
        follower = StoreFollower(runtime, reloader, store, poll_s=10.0, clock=clock)

        def poll_at(t: float) -> int:
            clock.now = 1000.0 + t
            asyncio.run(follower.poll())
            return len(loads)

        assert poll_at(0) == 0  # in step: nothing to load
        publish(store, scene, "svc-bad", broken=True)
        assert poll_at(1) == 1 and follower.failures == 1
        assert poll_at(1 + 19.9) == 1  # backoff_s(10, 1) = 20 s not yet passed
        assert poll_at(1 + 20) == 2 and follower.failures == 2
        assert poll_at(21 + 39.9) == 2  # then 40 s
        assert poll_at(21 + 40) == 3 and follower.failures == 3
        publish(store, scene, "svc-v2")  # another version: at once
        assert poll_at(62) == 4 and follower.failures == 0 and runtime.serving.model_version \
            == "svc-v2"
        assert poll_at(63) == 4  # in step again


def test_an_admin_reload_of_another_folder_holds_until_current_moves(scene, store, tmp_path):
    other = write_bundle(tmp_path / "explicit", scene, version="svc-explicit")
    with follower_app(scene, store, admin_token=TOKEN) as client:
        response = client.post("/v1/admin/reload", json={"bundle": str(other)},
                               headers={"Authorization": f"Bearer {TOKEN}"})
        assert response.status_code == 200, response.text
        time.sleep(10 * POLL_S)
        assert served(client) == "svc-explicit"  # the store's unchanged current does not undo it
        assert client.get("/v1/models").json()["store"]["served"] is None
        publish(store, scene, "svc-v2")
        wait_for(lambda: served(client) == "svc-v2")


def test_poll_zero_turns_following_off(scene, store):
    with follower_app(scene, store, store_poll_s=0) as client:
        publish(store, scene, "svc-v2")
        time.sleep(10 * POLL_S)
        assert served(client) == "svc-v1"
        assert client.get("/v1/models").json()["store"] is None


def test_a_plain_bundle_folder_is_watched_but_has_no_current(scene, tmp_path):
    plain = write_bundle(tmp_path / "plain", scene, version="svc-plain")
    with follower_app(scene, plain) as client:
        time.sleep(4 * POLL_S)
        status = client.get("/v1/models").json()["store"]
        assert status["current"] is None and status["served"] is None
        assert status["failures"] == 0 and served(client) == "svc-plain"


def test_shutdown_stops_the_follower_even_mid_load(scene, store):
    """A load still running at shutdown is abandoned, never installed."""
    gate = threading.Event()
    with follower_app(scene, store) as client:
        runtime, reloader = client.app.state.runtime, client.app.state.reloader
        follower = wait_for(lambda: runtime.follower)
        real_reload = reloader.reload

        def stuck(*args, **kwargs):
            gate.wait(FOLLOW_WAIT_S)
            return real_reload(*args, **kwargs)

        reloader.reload = stuck
        publish(store, scene, "svc-v2")
        wait_for(lambda: reloader.step is None and follower.current == "svc-v2")
        started = time.monotonic()
    assert time.monotonic() - started < 1.0  # the lifespan did not wait for the load
    assert runtime.follower is None and runtime.draining
    gate.set()
    time.sleep(0.3)  # the abandoned load ends: refused, the server was shutting down
    assert runtime.serving.model_version == "svc-v1"


def test_a_server_process_follows_the_store_and_exits_cleanly(scene, store):
    """`impactnet serve` configured by the environment: it follows, names itself, and a
    SIGTERM ends it with status 0 while its follower runs."""
    env = {"IMPACTNET_STORE_POLL_S": str(2 * POLL_S), "IMPACTNET_REPLICA_NAME": "r1",
           "IMPACTNET_SMOKE_POSES": str(SMOKE_POSES), "IMPACTNET_DRAIN_DELAY_S": "0"}
    proc = ServerProcess(args=["--scene", str(scene), "--bundle", str(store),
                               "--no-access-log"], env=env)
    try:
        proc.wait_ready()
        publish(store, scene, "svc-v2")

        def models() -> tuple[dict, dict]:
            conn = http.client.HTTPConnection("127.0.0.1", proc.port, timeout=5)
            try:
                conn.request("GET", "/v1/models")
                response = conn.getresponse()
                return dict(response.getheaders()), json.loads(response.read())
            finally:
                conn.close()

        headers, body = wait_for(lambda: (m := models())[1]["model_version"] == "svc-v2" and m)
        assert headers["x-replica"] == "r1" and body["replica"] == "r1"
        assert body["store"]["in_sync"] and body["store"]["poll_s"] == 2 * POLL_S
        assert proc.stop(timeout=10) == 0
        assert '"followed the store"' in proc.output()
    finally:
        proc.cleanup()


# ----------------------------------------------------------------------------- replica


@pytest.mark.parametrize("path,method,status", [
    ("/v2/contact", "post", 200), ("/v1/models", "get", 200), ("/healthz", "get", 200),
    ("/metrics", "get", 200), ("/v1/nowhere", "get", 404), ("/v2/contact", "get", 405),
])
def test_every_answer_names_its_replica(make_client, path, method, status):
    client = make_client(replica_name="replica-7")
    kwargs = {"json": PAIR} if method == "post" else {}
    response = getattr(client, method)(path, **kwargs)
    assert response.status_code == status
    assert response.headers["x-replica"] == "replica-7"


def test_the_default_replica_name_is_host_and_port(make_client):
    client = make_client(port=8123)
    name = f"{socket.gethostname()}:8123"
    assert client.get("/healthz").headers["x-replica"] == name
    assert client.get("/v1/models").json()["replica"] == name


def test_a_replica_name_is_made_header_safe(make_client):
    client = make_client(replica_name="a b\r\nX-Evil: 1")
    assert client.get("/healthz").headers["x-replica"] == "a_b__X-Evil:_1"
    assert "x-evil" not in client.get("/healthz").headers
