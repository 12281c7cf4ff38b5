"""The learned modes served from a bundle (the tests' tiny fixture bundle, never the shipped
one): single / committee / auto for one pair and for batches (JSON and npz), who answered,
unsupported pairs (422), /v1/models, metrics, the default mode, startup refusals (exit 2)."""
from __future__ import annotations

import re

import numpy as np
import pytest
from fastapi.testclient import TestClient

from impactnet.models import load_predictor
from impactnet.models.geometry.rotations import random_quaternions
from impactnet.service import cli
from impactnet.service.app import create_app
from tests.service.answer_paths import assert_same_answer
from tests.service.conftest import ServerProcess, assert_error, test_settings
from tests.service.learned import corrupt, write_bundle, write_scene
from tests.service.test_batch import NPZ, as_json, load_npz, npz_bytes
from tests.service.test_settings import _args

URL, BATCH = "/v2/contact", "/v2/contact/batch"
MODES = ("single", "committee", "auto")
BRICK, SLAB, CUBE = [1.0, 0.6, 0.4], [2.0, 1.5, 0.3], [1.0, 1.0, 1.0]
#: A brick lying on a slab, 1 mm deep, slightly turned.
ON_SLAB = {"a": {"object": "brick", "position": [0.1, 0.05, 0.349], "euler": [0.02, 0.01, 0.3]},
           "b": {"object": "slab", "position": [0.0, 0.0, 0.0], "quaternion": [1, 0, 0, 0]}}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("learned")
    scene = write_scene(root / "scenes")
    return {"root": root, "scene": scene, "bundle": write_bundle(root / "bundle", scene)}


@pytest.fixture(scope="module")
def learned(files):
    """A ready app serving the test scene and its bundle."""
    app = create_app(test_settings(scene=str(files["scene"]), bundle=str(files["bundle"])))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def _direct(mode, files, columns):
    predictor = load_predictor(mode, files["bundle"])
    return predictor(*(columns[k] for k in ("a_size", "a_position", "a_quaternion", "b_size",
                                            "b_position", "b_quaternion")))


def _mixed(n: int, seed: int = 0) -> dict:
    """n pairs: brick/slab, slab/brick (swapped), cube/cube, around contact."""
    rng = np.random.default_rng(seed)
    kind = np.arange(n) % 3
    size_a = np.where(kind[:, None] == 0, BRICK, np.where(kind[:, None] == 1, SLAB, CUBE))
    size_b = np.where(kind[:, None] == 0, SLAB, np.where(kind[:, None] == 1, BRICK, CUBE))
    return {"a_size": size_a, "a_position": rng.normal(scale=0.2, size=(n, 3)),
            "a_quaternion": random_quaternions(n, rng), "b_size": size_b,
            "b_position": rng.normal(scale=0.5, size=(n, 3)),
            "b_quaternion": random_quaternions(n, rng)}


# ----------------------------------------------------------------------------- /v1/models


def test_models_reports_the_bundle(learned, files):
    response = learned.get("/v1/models")
    assert response.status_code == 200
    body = response.json()
    assert body["model_version"] == "svc-test-1" == response.headers["x-model-version"]
    assert body["modes"] == {"available": ["exact", "single", "committee", "auto"],
                             "unavailable": {}, "default": "auto"}
    bundle = body["bundle"]
    assert bundle["name"] == files["bundle"].name
    assert str(files["bundle"].parent) not in str(body)  # no server path shown
    assert bundle["version"] == "svc-test-1" and bundle["created_utc"]
    assert bundle["scene"] == {"name": "svc_test", "hash": body["scene"]["hash"]}
    assert set(bundle["files"]["weights.safetensors"]) == {"sha256", "bytes"}
    assert set(bundle["pairs"]) == {"brick/slab", "cube/cube"}
    pair = bundle["pairs"]["brick/slab"]
    assert pair["size_a"] == BRICK and pair["modes"] == ["single", "committee", "auto"]
    assert pair["validation"] == {"region_accuracy": 0.9, "normal_median_deg": 3.0}
    assert set(pair["auto"]) == {"confidence_min", "normal_spread_max_deg",
                                 "point_spread_max", "depth_margin"}
    assert pair["serve"] == "learned" and pair["decision"] is None  # no decision recorded
    assert bundle["scene_pairs_covered"] == ["brick/slab", "cube/cube"]
    assert bundle["scene_pairs_not_covered"] == ["plank/cube"]
    smoke = bundle["smoke"]["pairs"]["cube/cube"]["committee"]
    assert smoke["normal_median_deg"] < 15 and smoke["colliding_agreement"] > 0.8


def test_a_pair_the_bundle_serves_exact_only_is_answered_exactly_in_every_mode(files):
    """Issue #21: the recorded decision reaches the API: /v1/models shows it, and every mode
    answers the pair as mode exact does, naming the exact solver."""
    folder = write_bundle(files["root"] / "decided", files["scene"], version="svc-decided",
                          exact_only=("brick/slab",))
    app = create_app(test_settings(scene=str(files["scene"]), bundle=str(folder)))
    with TestClient(app) as client:
        pairs = client.get("/v1/models").json()["bundle"]["pairs"]
        assert pairs["brick/slab"]["serve"] == "exact-only"
        assert pairs["brick/slab"]["decision"]["speedup_n1"] == 0.9
        assert pairs["cube/cube"]["serve"] == "learned"
        exact = client.post(URL, json=ON_SLAB | {"mode": "exact"}).json()
        for mode in ("single", "committee", "auto"):
            body = client.post(URL, json=ON_SLAB | {"mode": mode}).json()
            assert body["predictor"] == "exact", mode
            assert body["point"] == exact["point"] and body["normal"] == exact["normal"]


# ----------------------------------------------------------------------------- one pair


@pytest.mark.parametrize("mode", MODES)
def test_one_pair_in_each_learned_mode(learned, files, mode):
    response = learned.post(URL, json=ON_SLAB | {"mode": mode})
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["mode"] == mode and body["model_version"] == "svc-test-1"
    assert response.headers["x-model-version"] == "svc-test-1"
    assert body["predictor"] == {"single": "single", "committee": "committee"}.get(
        mode, body["predictor"]) and body["predictor"] in ("single", "committee", "exact")
    assert 0.0 <= body["confidence"] <= 1.0
    assert abs(np.linalg.norm(body["normal"]) - 1) < 1e-6
    # The same answer as the predictor called directly (the service converts the pose once).
    rows = learned.post(BATCH, json=_one_as_batch(learned) | {"mode": mode}).json()
    np.testing.assert_allclose(body["point"], rows["point"][0], atol=1e-9)
    assert body["predictor"] == rows["predictor"][0]


def _one_as_batch(client) -> dict:
    from impactnet.service.codecs.pair import euler_quaternion

    return {"a_object": "brick", "a_position": ON_SLAB["a"]["position"],
            "a_quaternion": euler_quaternion(ON_SLAB["a"]["euler"], "zyx"),
            "b_object": "slab", "b_position": [0, 0, 0], "b_quaternion": [1, 0, 0, 0]}


def test_default_mode_is_auto_with_a_bundle(learned, files):
    body = learned.post(URL, json=ON_SLAB).json()
    assert body["mode"] == "auto"
    # One answer: what `auto` of the same bundle answers for the same pose, called directly.
    pair = _one_as_batch(learned)
    columns = {"a_size": np.array(BRICK), "a_position": np.array(pair["a_position"]),
               "a_quaternion": np.array(pair["a_quaternion"]), "b_size": np.array(SLAB),
               "b_position": np.zeros(3), "b_quaternion": np.array([1.0, 0.0, 0.0, 0.0])}
    direct = _direct("auto", files, columns)
    assert body["predictor"] == direct.predictor[0]
    np.testing.assert_allclose(body["point"], direct.point[0], atol=1e-9)
    np.testing.assert_allclose(body["normal"], direct.normal[0], atol=1e-9)


def test_exact_mode_still_served_with_the_bundle_version(learned):
    body = learned.post(URL, json=ON_SLAB | {"mode": "exact"}).json()
    assert body["predictor"] == "exact" and body["confidence"] == 1.0
    assert body["model_version"] == "svc-test-1"


@pytest.mark.parametrize("mode", ["single", "committee"])
def test_strict_mode_on_an_uncovered_pair_is_422(learned, mode):
    body = ON_SLAB | {"a": ON_SLAB["a"] | {"object": "plank"}, "mode": mode}
    answer = assert_error(learned.post(URL, json=body), 422, "pair", "unsupported_pair")
    assert answer["mode"] == mode and "brick/slab, cube/cube" in answer["message"]
    raw = ON_SLAB | {"a": {"size": [0.5, 0.5, 0.5], "position": [0, 0, 0.4],
                           "quaternion": [1, 0, 0, 0]}, "mode": mode}
    assert_error(learned.post(URL, json=raw), 422, "pair", "unsupported_pair")


def test_auto_answers_an_uncovered_pair_with_exact(learned):
    body = ON_SLAB | {"a": ON_SLAB["a"] | {"object": "plank"}, "mode": "auto"}
    response = learned.post(URL, json=body)
    assert response.status_code == 200
    assert response.json()["predictor"] == "exact"


# ----------------------------------------------------------------------------- batches


@pytest.mark.parametrize("mode", MODES)
def test_batch_json_and_npz_equal_the_predictor(learned, files, mode):
    columns = _mixed(90, seed=3)
    response = learned.post(BATCH, json=as_json(columns, mode=mode))
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["n"] == 90 and body["mode"] == mode and body["model_version"] == "svc-test-1"
    expected = _direct(mode, files, columns)
    np.testing.assert_allclose(body["point"], expected.point, atol=1e-9)
    np.testing.assert_allclose(body["normal"], expected.normal, atol=1e-9)
    np.testing.assert_allclose(body["confidence"], expected.confidence, atol=1e-12)
    assert body["predictor"] == expected.predictor.tolist()
    binary = learned.post(BATCH + f"?mode={mode}", content=npz_bytes(columns),
                          headers={"Content-Type": NPZ, "Accept": NPZ})
    assert binary.status_code == 200 and binary.headers["x-model-version"] == "svc-test-1"
    out = load_npz(binary.content)
    np.testing.assert_array_equal(out["point"], np.array(body["point"]))
    np.testing.assert_array_equal(out["confidence"], np.array(body["confidence"]))
    assert out["predictor"].tolist() == body["predictor"]
    assert str(out["model_version"]) == "svc-test-1"
    assert_same_answer(body, out)  # every member of the one shape alike


@pytest.mark.parametrize("mode", ["single", "committee"])
def test_strict_batch_names_the_uncovered_rows(learned, mode):
    n = 12
    objects = np.array(["brick"] * n, dtype="<U8")
    objects[[2, 7]] = "plank"
    columns = {"a_object": objects.tolist(), "a_position": [0, 0, 0.349],
               "a_quaternion": [1, 0, 0, 0], "b_object": "slab", "b_position": [0, 0, 0],
               "b_quaternion": [1, 0, 0, 0], "mode": mode}
    body = assert_error(learned.post(BATCH, json=columns), 422, "pairs", "unsupported_pair")
    assert body["detail"][0]["rows"] == [2, 7] and "rows [2, 7]" in body["message"]
    binary = learned.post(BATCH + f"?mode={mode}", headers={"Content-Type": NPZ},
                          content=npz_bytes({k: np.asarray(v) for k, v in columns.items()
                                             if k != "mode"}))
    assert assert_error(binary, 422, "pairs", "unsupported_pair")["detail"][0]["rows"] == [2, 7]
    columns["mode"] = "auto"
    out = learned.post(BATCH, json=columns).json()
    assert [out["predictor"][i] for i in (2, 7)] == ["exact", "exact"]


def test_metrics_count_pairs_by_mode_and_predictor_and_auto_fallbacks(files):
    app = create_app(test_settings(scene=str(files["scene"]), bundle=str(files["bundle"])))
    with TestClient(app) as c:
        plank = ON_SLAB | {"a": ON_SLAB["a"] | {"object": "plank"}}
        assert c.post(URL, json=plank | {"mode": "auto"}).json()["predictor"] == "exact"
        assert c.post(URL, json=ON_SLAB | {"mode": "single"}).status_code == 200
        columns = _mixed(30, seed=1)
        answer = c.post(BATCH, json=as_json(columns, mode="auto")).json()
        text = c.get("/metrics").text
    fallen = 1 + answer["predictor"].count("exact")
    learned_rows = answer["predictor"].count("committee")

    def value(pattern: str) -> float:
        match = re.search(re.escape(pattern) + r" ([0-9.e+-]+)", text)
        assert match, pattern
        return float(match.group(1))

    assert value('impactnet_pairs_scored_total{mode="auto",predictor="exact"}') == fallen
    if learned_rows:
        assert value('impactnet_pairs_scored_total{mode="auto",predictor="committee"}') \
            == learned_rows
    assert value('impactnet_pairs_scored_total{mode="single",predictor="single"}') == 1
    assert value("impactnet_auto_fallback_pairs_total") == fallen
    assert value("impactnet_auto_fallback_rate") == pytest.approx(fallen / 31)
    assert 'model_version="svc-test-1"' in text


# ----------------------------------------------------------------------------- startup


def test_default_mode_can_be_overridden(files):
    settings = test_settings(scene=str(files["scene"]), bundle=str(files["bundle"]),
                             default_mode="committee")
    with TestClient(create_app(settings)) as c:
        assert c.get("/v1/models").json()["modes"]["default"] == "committee"
        assert c.post(URL, json=ON_SLAB).json()["predictor"] == "committee"


def test_shipped_bundle_of_the_scene_is_the_default(files, monkeypatch):
    import impactnet.service.state

    shipped = files["root"] / "shipped"
    write_bundle(shipped / "svc_test", files["scene"], version="svc-shipped")
    monkeypatch.setattr(impactnet.service.state, "BUNDLES_DIR", shipped)
    settings = test_settings(scene=str(files["scene"]), bundle=None)
    with TestClient(create_app(settings)) as c:
        assert c.get("/v1/models").json()["model_version"] == "svc-shipped"
    with TestClient(create_app(test_settings(scene=str(files["scene"])))) as c:  # "none"
        body = c.get("/v1/models").json()
    assert body["bundle"] is None and body["modes"]["default"] == "exact"
    assert body["modes"]["unavailable"]["auto"].startswith("no learned bundle")


@pytest.mark.parametrize("case,message", [
    ("scene_hash", "was built for scene 'svc_test' with hash 000000000000"),
    ("corrupt", "refused"),
    ("missing", "no such folder"),
    ("smoke", "failed the smoke test"),
    ("mode", "default mode 'single' is not served"),
])
def test_a_bundle_that_cannot_serve_exits_2_at_startup(files, capsys, case, message):
    folder = files["root"] / f"bad-{case}"
    if case == "scene_hash":
        write_bundle(folder, files["scene"], scene_hash="0" * 64)
    elif case == "corrupt":
        corrupt(write_bundle(folder, files["scene"]))
    elif case == "smoke":
        write_bundle(folder, files["scene"], nonsense_outputs=True)
    argv = ["--scene", str(files["scene"]), "--bundle", str(folder)]
    if case == "mode":
        argv = ["--scene", str(files["scene"]), "--bundle", "none", "--default-mode", "single"]
    assert cli.run(_args(*argv)) == cli.EXIT_CONFIG
    err = capsys.readouterr().err
    assert message in err, err


def test_scene_hash_mismatch_stops_a_real_server(files):
    folder = files["root"] / "other-scene"
    write_bundle(folder, files["scene"], scene_hash="f" * 64)
    proc = ServerProcess(args=["--scene", str(files["scene"]), "--bundle", str(folder)])
    try:
        assert proc.proc.wait(60) == 2
        assert "scene_hash" in proc.output() and "ffffffffffff" in proc.output()
    finally:
        proc.cleanup()


def test_learned_default_mode_without_bundle_is_not_ready(make_client):
    c = make_client(default_mode="auto")
    response = c.get("/readyz")
    assert response.status_code == 503
    assert "default mode 'auto' is not served" in response.json()["reason"]
