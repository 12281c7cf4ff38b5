"""POST /v1/admin/reload: off without a token (404), 401 / 403 for missing / wrong tokens, a
good bundle swapped in, a bad one (flipped byte, other scene, failing smoke test, missing)
refused with the step while the old one keeps serving, reloads serialised."""
from __future__ import annotations

import re
import shutil
import threading

import pytest
from fastapi.testclient import TestClient

import impactnet.service.state
from impactnet.service.app import create_app
from tests.service.conftest import assert_error, test_settings
from tests.service.learned import corrupt, write_bundle, write_scene
from tests.service.test_learned import ON_SLAB

RELOAD = "/v1/admin/reload"
TOKEN = "test-admin-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("reload")
    scene = write_scene(root / "scenes")
    return {"root": root, "scene": scene,
            "v1": write_bundle(root / "v1", scene, version="svc-v1"),
            "v2": write_bundle(root / "v2", scene, version="svc-v2")}


@pytest.fixture
def admin(files, tmp_path):
    """A fresh app serving a copy of bundle v1 (so tests may rewrite it), token set."""
    configured = tmp_path / "configured"
    shutil.copytree(files["v1"], configured)
    settings = test_settings(scene=str(files["scene"]), bundle=str(configured),
                             admin_token=TOKEN)
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        c.configured = configured
        yield c


def _version(client) -> str:
    response = client.post("/v2/contact", json=ON_SLAB)
    assert response.status_code == 200
    assert response.headers["x-model-version"] == response.json()["model_version"]
    return response.json()["model_version"]


# ----------------------------------------------------------------------------- access


def test_without_a_token_the_route_does_not_exist(files):
    settings = test_settings(scene=str(files["scene"]), bundle=str(files["v1"]))
    with TestClient(create_app(settings)) as c:
        assert_error(c.post(RELOAD, json={}), 404, None, "not_found")
        assert_error(c.post(RELOAD, json={}, headers=AUTH), 404, None, "not_found")
        assert RELOAD not in c.get("/openapi.json").json()["paths"]
    with TestClient(create_app(test_settings(admin_token=""))) as c:  # empty: off too
        assert_error(c.post(RELOAD), 404, None, "not_found")


def test_missing_or_wrong_token(admin, files):
    body = {"bundle": str(files["v2"])}
    response = admin.post(RELOAD, json=body)
    assert_error(response, 401, None, "unauthorized")
    assert response.headers["www-authenticate"].startswith("Bearer")
    assert_error(admin.post(RELOAD, json=body, headers={"Authorization": f"Basic {TOKEN}"}),
                 401, None, "unauthorized")
    assert_error(admin.post(RELOAD, json=body, headers={"Authorization": "Bearer"}),
                 401, None, "unauthorized")
    assert_error(admin.post(RELOAD, json=body, headers={"Authorization": "Bearer wrong"}),
                 403, None, "forbidden")
    assert_error(admin.post(RELOAD, json=body,
                            headers={"Authorization": f"Bearer {TOKEN}x"}), 403)
    assert _version(admin) == "svc-v1"  # nothing was reloaded
    assert RELOAD in admin.get("/openapi.json").json()["paths"]


# ----------------------------------------------------------------------------- success


def test_reload_swaps_the_version(admin, files):
    assert _version(admin) == "svc-v1"
    response = admin.post(RELOAD, json={"bundle": str(files["v2"])}, headers=AUTH)
    assert response.status_code == 200, response.text
    report = response.json()
    assert report["reloaded"] is True and report["model_version"] == "svc-v2"
    assert report["previous_model_version"] == "svc-v1"
    assert report["bundle"] == str(files["v2"].resolve())
    assert report["modes"] == ["exact", "single", "committee", "auto"]
    assert set(report["smoke"]["pairs"]) == {"brick/slab", "cube/cube"}
    assert response.headers["x-model-version"] == "svc-v2"
    assert _version(admin) == "svc-v2"
    models = admin.get("/v1/models").json()
    assert models["bundle"]["version"] == "svc-v2"
    assert models["bundle"]["name"] == files["v2"].name
    text = admin.get("/metrics").text
    assert re.search(r'impactnet_bundle_reloads_total\{result="ok",step=""\} 1', text)
    assert 'impactnet_model_info{model_version="svc-v2"' in text
    assert 'model_version="svc-v1"' not in text


def test_empty_body_rereads_the_configured_folder(admin, files):
    write_bundle(admin.configured, files["scene"], version="svc-v3")  # replaced in place
    assert _version(admin) == "svc-v1"  # not before the reload
    for kwargs in ({}, {"json": {}}):
        response = admin.post(RELOAD, headers=AUTH, **kwargs)
        assert response.status_code == 200, response.text
        assert response.json()["model_version"] == "svc-v3"
    assert _version(admin) == "svc-v3"


def test_reload_from_an_exact_only_server(files):
    settings = test_settings(scene=str(files["scene"]), admin_token=TOKEN)  # bundle "none"
    with TestClient(create_app(settings)) as c:
        assert c.get("/v1/models").json()["modes"]["default"] == "exact"
        assert_error(c.post(URL := "/v2/contact", json=ON_SLAB | {"mode": "committee"}), 409)
        body = assert_error(c.post(RELOAD, headers=AUTH), 409, "bundle", "reload_failed")
        assert body["step"] == "resolve" and "no bundle path is configured" in body["message"]
        response = c.post(RELOAD, json={"bundle": str(files["v2"])}, headers=AUTH)
        assert response.status_code == 200, response.text
        answer = c.post(URL, json=ON_SLAB | {"mode": "committee"}).json()
        assert answer["predictor"] == "committee" and answer["model_version"] == "svc-v2"
        assert c.get("/v1/models").json()["modes"]["default"] == "auto"


# ----------------------------------------------------------------------------- failures


@pytest.mark.parametrize("case,step", [
    ("corrupt", "read"), ("missing", "read"), ("scene_hash", "scene_hash"),
    ("smoke", "smoke"), ("not_a_bundle", "read"),
])
def test_a_bad_bundle_is_refused_and_the_old_keeps_serving(admin, files, tmp_path, case,
                                                           step):
    folder = tmp_path / "new"
    if case == "corrupt":
        corrupt(write_bundle(folder, files["scene"], version="svc-bad"))
    elif case == "scene_hash":
        write_bundle(folder, files["scene"], version="svc-bad", scene_hash="a" * 64)
    elif case == "smoke":
        write_bundle(folder, files["scene"], version="svc-bad", nonsense_outputs=True)
    elif case == "not_a_bundle":
        folder.mkdir()
        (folder / "manifest.json").write_text("{}")
    response = admin.post(RELOAD, json={"bundle": str(folder)}, headers=AUTH)
    body = assert_error(response, 422, "bundle", "reload_failed")
    assert body["step"] == step and body["model_version"] == "svc-v1"
    assert body["bundle"] == str(folder) and f"step '{step}'" in body["message"]
    assert _version(admin) == "svc-v1"
    assert admin.get("/readyz").status_code == 200
    assert admin.get("/v1/models").json()["bundle"]["version"] == "svc-v1"
    text = admin.get("/metrics").text
    assert f'impactnet_bundle_reloads_total{{result="failed",step="{step}"}} 1.0' in text


def test_corrupting_the_configured_folder_keeps_the_loaded_bundle(admin):
    corrupt(admin.configured)
    body = assert_error(admin.post(RELOAD, headers=AUTH), 422, "bundle", "reload_failed")
    assert body["step"] == "read" and "sha-256 differs" in body["message"].lower()
    assert _version(admin) == "svc-v1"
    assert admin.post("/v2/contact", json=ON_SLAB | {"mode": "single"}).status_code == 200


@pytest.mark.parametrize("content,headers,status", [
    (b'{"bundle": ', {"Content-Type": "application/json"}, 422),
    (b'{"path": "x"}', {"Content-Type": "application/json"}, 422),
    (b'{"bundle": ""}', {"Content-Type": "application/json"}, 422),
    (b'{"bundle": 3}', {"Content-Type": "application/json"}, 422),
    (b'bundle=x', {"Content-Type": "application/x-www-form-urlencoded"}, 415),
    # regression (schemathesis): whitespace alone is not an empty body, and not JSON
    (b' \t\r\n', {"Content-Type": "application/json"}, 422),
])
def test_bad_reload_bodies(admin, content, headers, status):
    assert_error(admin.post(RELOAD, content=content, headers=AUTH | headers), status)
    assert _version(admin) == "svc-v1"


def test_reloads_are_serialised(admin, files, monkeypatch):
    active, overlap = [0], []
    real = impactnet.service.state.state_for
    gate = threading.Lock()

    def tracked(*args, **kwargs):
        with gate:
            active[0] += 1
            overlap.append(active[0])
        try:
            threading.Event().wait(0.05)
            return real(*args, **kwargs)
        finally:
            with gate:
                active[0] -= 1

    monkeypatch.setattr("impactnet.service.reload.state_for", tracked)
    reloader = admin.app.state.reloader
    results = []
    threads = [threading.Thread(target=lambda p=p: results.append(reloader.reload(str(p))))
               for p in (files["v1"], files["v2"], files["v1"], files["v2"])]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert len(results) == 4 and max(overlap) == 1
    assert _version(admin) == results[-1]["model_version"]
    previous = [r["previous_model_version"] for r in results[1:]]
    assert previous == [r["model_version"] for r in results[:-1]]  # each on the last one
