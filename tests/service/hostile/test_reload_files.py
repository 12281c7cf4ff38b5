"""Issue 23, item 5: an admin reload cannot hang, nor read without end.

Reproducers: with ``manifest.json`` a FIFO, the reload blocked forever, holding the reload lock
and a worker thread; a manifest linked to /dev/zero would be read without end. Now the files
are checked first (regular files, size caps, the weights' header length), and a reload has a
deadline after which it answers, and its bundle is never installed. Each call here runs under
its own bound, so that a regression fails instead of hanging the suite.
"""
from __future__ import annotations

import os
import shutil
import threading
import time

import pytest
from fastapi.testclient import TestClient

from impactnet.service.app import create_app
from impactnet.service.limits.bundle_guard import WEIGHTS_HEADER_MAX_BYTES
from impactnet.service.state import state_for
from tests.service.conftest import assert_error, test_settings
from tests.service.learned import write_bundle, write_scene

TOKEN = "reload-files-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
RELOAD = "/v1/admin/reload"
#: Seconds any one reload call may take here (the checks answer in milliseconds).
CALL_BOUND_S = 20.0
#: Smoke-test poses per pair: the fewest allowed, the smoke test is not under test here.
SMOKE_POSES = 8


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("reload-files")
    scene = write_scene(root / "scenes")
    return {"scene": scene, "v1": write_bundle(root / "v1", scene, version="files-v1"),
            "v2": write_bundle(root / "v2", scene, version="files-v2")}


@pytest.fixture
def admin(files):
    settings = test_settings(scene=str(files["scene"]), bundle=str(files["v1"]),
                             admin_token=TOKEN, reload_timeout_s=5.0, smoke_poses=SMOKE_POSES)
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        yield client


def _bounded(call):
    """``call()`` in a thread; fails the test if it has not returned in CALL_BOUND_S."""
    result = []
    worker = threading.Thread(target=lambda: result.append(call()), daemon=True)
    worker.start()
    worker.join(CALL_BOUND_S)
    assert result, f"the call did not return within {CALL_BOUND_S} s"
    return result[0]


def _reload(admin, folder=None):
    body = {} if folder is None else {"bundle": str(folder)}
    return _bounded(lambda: admin.post(RELOAD, json=body, headers=AUTH))


def _version(admin) -> str:
    return admin.get("/v1/models").json()["model_version"]


def _broken(tmp_path, files, case: str):
    folder = tmp_path / case
    shutil.copytree(files["v2"], folder)
    if case == "manifest_fifo":
        os.unlink(folder / "manifest.json")
        os.mkfifo(folder / "manifest.json")
    elif case == "manifest_dev_zero":
        os.unlink(folder / "manifest.json")
        os.symlink("/dev/zero", folder / "manifest.json")
    elif case == "weights_fifo":
        os.unlink(folder / "weights.safetensors")
        os.mkfifo(folder / "weights.safetensors")
    elif case == "weights_header":
        weights = folder / "weights.safetensors"
        data = bytearray(weights.read_bytes())
        data[:8] = (WEIGHTS_HEADER_MAX_BYTES + 1).to_bytes(8, "little")
        weights.write_bytes(bytes(data))
    elif case == "pointer_fifo":
        store = tmp_path / "store"
        (store / "versions").mkdir(parents=True)
        shutil.move(folder, store / "versions" / "files-v2")
        os.mkfifo(store / "current")
        return store
    return folder


@pytest.mark.parametrize("case,reason", [
    ("manifest_fifo", "not a regular file"), ("manifest_dev_zero", "not a regular file"),
    ("weights_fifo", "not a regular file"), ("weights_header", "safetensors header"),
    ("pointer_fifo", "not a regular file"),
])
def test_a_file_that_could_block_is_refused_at_once(admin, files, tmp_path, case, reason):
    started = time.monotonic()
    body = assert_error(_reload(admin, _broken(tmp_path, files, case)), 422, "bundle",
                        "reload_failed")
    assert time.monotonic() - started < 5
    assert body["step"] == "read" and reason in body["message"]
    assert _version(admin) == "files-v1"
    response = _reload(admin, files["v2"])  # the lock is free, no thread was lost
    assert response.status_code == 200 and _version(admin) == "files-v2"


def test_a_reload_past_its_deadline_answers_and_never_installs(files, monkeypatch):
    release = threading.Event()

    def slow(scene, path, settings, on_step):
        on_step("smoke")
        release.wait(CALL_BOUND_S)
        return state_for(scene, path, settings)

    settings = test_settings(scene=str(files["scene"]), bundle=str(files["v1"]),
                             admin_token=TOKEN, reload_timeout_s=0.5, smoke_poses=SMOKE_POSES)
    with TestClient(create_app(settings), raise_server_exceptions=False) as admin:
        monkeypatch.setattr("impactnet.service.reload.state_for", slow)
        body = assert_error(_reload(admin, files["v2"]), 422, "bundle", "reload_failed")
        assert body["step"] == "smoke" and "did not finish within 0.5 s" in body["message"]
        waiting = assert_error(_reload(admin, files["v2"]), 409, "bundle", "reload_failed")
        assert "another reload is still running" in waiting["message"]
        release.set()
        for _ in range(100):  # the late reload ends by itself, without installing
            if 'step="install"} 1.0' in admin.get("/metrics").text:
                break
            time.sleep(0.05)
        assert 'impactnet_bundle_reloads_total{result="failed",step="install"} 1.0' in \
            admin.get("/metrics").text
        assert _version(admin) == "files-v1"
        monkeypatch.undo()
        assert _reload(admin, files["v2"]).status_code == 200
        assert _version(admin) == "files-v2"
