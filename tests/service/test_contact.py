"""POST /v2/contact: answers in the one shape (a box is a body of one part), the gap within a
margin, and every kind of bad input (status code first); the old paths answer 410."""
from __future__ import annotations

import math

import numpy as np
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.geometry.rotations import euler_to_quaternion, quaternion_to_matrix
from tests.service.conftest import PAIR, assert_error, pair

#: Round-off allowed on a gap and its closest points (metres).
GAP_ATOL_M = 1e-12

FIELDS = {"colliding", "point", "normal", "depth", "distance", "closest_a", "closest_b",
          "contact_type", "feature_a", "feature_b", "predictor", "confidence", "cluster_size",
          "contacts", "mode", "model_version"}
CONTACT_FIELDS = {"part_a", "part_b", "point", "normal", "depth", "contact_type", "feature_a",
                  "feature_b", "axis", "pressure"}


def _exact(body):
    q_b = euler_to_quaternion(body["b"]["euler"])[0]
    return box_box(body["a"]["size"], body["a"]["position"], body["a"]["quaternion"],
                   body["b"]["size"], body["b"]["position"], q_b)


def test_answer_matches_exact_solver(client):
    response = client.post("/v2/contact", json=PAIR)
    assert response.status_code == 200
    body = response.json()
    assert set(body) == FIELDS
    expected = _exact(PAIR)
    assert body["colliding"] is True
    np.testing.assert_array_equal(body["point"], expected.point[0])
    np.testing.assert_array_equal(body["normal"], expected.normal[0])
    assert body["depth"] == expected.depth[0]
    assert body["contact_type"] == expected.contact_type[0]
    assert body["distance"] == -body["depth"]
    assert body["closest_a"] is None and body["closest_b"] is None
    assert body["feature_a"] == {"part": "box", "id": int(expected.feature_a[0]),
                                 "name": "face +z", "kind": "face"}
    assert body["feature_b"]["id"] == int(expected.feature_b[0])
    assert body["feature_b"]["part"] == "box"
    assert body["predictor"] == "exact" and body["mode"] == "exact"
    assert body["confidence"] == 1.0 and body["cluster_size"] == 1
    # two boxes: one part contact, the body level's own values and the solver's axis
    (contact,) = body["contacts"]
    assert set(contact) == CONTACT_FIELDS
    assert contact["part_a"] == contact["part_b"] == "box"
    for key in ("point", "normal", "depth", "contact_type"):
        assert contact[key] == body[key], key
    assert contact["feature_a"] == {k: body["feature_a"][k] for k in ("id", "name", "kind")}
    assert contact["feature_b"]["id"] == body["feature_b"]["id"]
    assert contact["axis"] == int(expected.axis[0])
    assert contact["pressure"] == expected.pressure[0]
    assert body["model_version"].startswith("exact-")
    assert response.headers["x-model-version"] == body["model_version"]
    assert response.headers["content-type"] == "application/json"


@pytest.mark.parametrize("convention", ["zyx", "xyz"])
def test_plain_float_euler_equals_models_rotations(convention):
    from impactnet.service.codecs.pair import euler_quaternion

    angles = np.random.default_rng(0).uniform(-7, 7, size=(500, 3))
    ours = np.array([euler_quaternion(e.tolist(), convention) for e in angles])
    np.testing.assert_allclose(ours, euler_to_quaternion(angles, convention), rtol=0,
                               atol=4e-16)


def test_single_equals_batch_row(client):
    single = client.post("/v2/contact", json=PAIR).json()
    batch = client.post("/v2/contact/batch", json={
        "a_size": PAIR["a"]["size"], "a_position": [PAIR["a"]["position"]] * 2,
        "a_quaternion": PAIR["a"]["quaternion"], "b_size": PAIR["b"]["size"],
        "b_position": PAIR["b"]["position"], "b_euler": PAIR["b"]["euler"]}).json()
    for key in ("point", "normal", "depth"):
        assert batch[key][0] == batch[key][1]
        np.testing.assert_allclose(batch[key][0], single[key], rtol=0, atol=1e-12)
    assert batch["contact_type"][0] == single["contact_type"]
    assert batch["feature_a"]["name"][0] == single["feature_a"]["name"]
    assert batch["contacts"]["offsets"] == [0, 1, 2]
    assert batch["contacts"]["axis"][0] == single["contacts"][0]["axis"]


def test_separated_pair_has_no_contact(client):
    response = client.post("/v2/contact", json=pair(b_position=[10.0, 0.0, 0.0]))
    assert response.status_code == 200
    body = response.json()
    assert body["colliding"] is False and body["contact_type"] == "none"
    assert body["depth"] == 0.0 and body["contacts"] == [] and body["cluster_size"] == 0
    assert body["feature_a"] == {"part": None, "id": -1, "name": "none", "kind": "none"}
    # no margin: no gap, no closest points
    assert body["distance"] is None
    assert body["closest_a"] is None and body["closest_b"] is None
    assert np.linalg.norm(body["normal"]) == pytest.approx(1.0)  # the separating direction


def test_a_pair_within_the_margin_answers_its_gap_and_closest_points(client):
    apart = pair(b_position=[0.0, 0.0, 2.5], b_euler=[0.0, 0.0, 0.0])  # faces 0.5 m apart
    body = client.post("/v2/contact", json=apart | {"margin": 1.0}).json()
    assert body["colliding"] is False and body["contacts"] == []
    assert body["distance"] == pytest.approx(0.5, abs=GAP_ATOL_M)
    assert body["closest_a"][2] == pytest.approx(1.0, abs=GAP_ATOL_M)
    assert body["closest_b"][2] == pytest.approx(1.5, abs=GAP_ATOL_M)
    np.testing.assert_allclose(body["normal"], [0.0, 0.0, 1.0], atol=GAP_ATOL_M)
    assert body["feature_a"]["part"] == body["feature_b"]["part"] == "box"
    beyond = client.post("/v2/contact", json=apart | {"margin": 0.4}).json()
    assert beyond["distance"] is None and beyond["closest_a"] is None


@pytest.mark.parametrize("margin", [-0.1, 100.5, "1"])
def test_a_margin_out_of_range_is_422(client, margin):
    assert_error(client.post("/v2/contact", json=pair(margin=margin)), 422, "margin",
                 "invalid_input")


@pytest.mark.parametrize("old, new", [("/v1/contact", "/v2/contact"),
                                      ("/v1/contact/batch", "/v2/contact/batch")])
def test_the_old_paths_answer_410_naming_the_new_one(client, old, new):
    body = assert_error(client.post(old, json=PAIR), 410, None, "moved")
    assert body["new_path"] == new and new in body["message"]


def test_orientations_agree(client):
    """quaternion, matrix and euler of the same rotation give the same answer."""
    q = euler_to_quaternion([0.05, 0.0, 0.0])[0]
    answers = [client.post("/v2/contact", json=pair(b_euler=None, **{f"b_{k}": v})).json()
               for k, v in (("quaternion", q.tolist()),
                            ("matrix", quaternion_to_matrix(q)[0].tolist()))]
    answers.append(client.post("/v2/contact", json=PAIR).json())
    for other in answers[1:]:
        np.testing.assert_allclose(other["point"], answers[0]["point"], atol=1e-12)
        np.testing.assert_allclose(other["normal"], answers[0]["normal"], atol=1e-12)
        assert other["contact_type"] == answers[0]["contact_type"]


def test_euler_convention_xyz(client):
    zyx = client.post("/v2/contact", json=pair(b_euler=[0.05, 0.02, 0.0])).json()
    # a rotation about x then y: xyz [a, b, 0] = Rx(a) Ry(b), zyx [roll, pitch, 0] = Ry Rx
    xyz = client.post("/v2/contact", json=pair(b_euler=[0.05, 0.02, 0.0],
                                                euler_convention="xyz")).json()
    assert xyz["point"] != zyx["point"]


def test_scene_objects(client):
    body = {"a": {"object": "container40", "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
            "b": {"object": "spreader", "position": [0, 0, 1.69], "euler": [0, 0, 0.01]}}
    response = client.post("/v2/contact", json=body)
    assert response.status_code == 200
    raw = client.post("/v2/contact", json={
        "a": {"size": [12.192, 2.438, 2.591], "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
        "b": {"size": [12.0, 2.35, 0.8], "position": [0, 0, 1.69], "euler": [0, 0, 0.01]}})
    assert response.json()["point"] == raw.json()["point"]
    assert response.json()["contact_type"] == "face-face"


def test_include_manifold_and_paper_angles(client):
    response = client.post("/v2/contact", json=pair(include=["manifold", "paper_angles"]))
    assert response.status_code == 200
    body = response.json()
    manifold = body["contacts"][0]["manifold"]
    assert manifold["count"] == len(manifold["points"]) == len(manifold["depths"]) >= 1
    # the manifold is the library's (the incident face's clip, deepest first) and the point
    # is the library's centre of pressure, which need not be a mean of the manifold
    expected = _exact(PAIR)
    count = int(expected.manifold_count[0])
    assert manifold["count"] == count
    np.testing.assert_array_equal(manifold["points"], expected.manifold_points[0, :count])
    np.testing.assert_array_equal(manifold["depths"], expected.manifold_depths[0, :count])
    assert manifold["depths"] == sorted(manifold["depths"], reverse=True)
    np.testing.assert_array_equal(body["point"], expected.point[0])
    # [point azimuth, point elevation, force azimuth, force elevation]
    angles = body["paper_angles"]
    assert len(angles) == 4 and all(math.isfinite(v) for v in angles)
    assert math.isclose(angles[3], math.pi / 2)  # normal +z in A's frame
    separated = client.post("/v2/contact", json=pair(b_position=[9, 0, 0],
                                                      include=["paper_angles"])).json()
    assert separated["paper_angles"] is None


def test_request_id_is_honoured_and_returned(client):
    response = client.post("/v2/contact", json=PAIR, headers={"X-Request-ID": "sim-42.7"})
    assert response.status_code == 200
    assert response.headers["x-request-id"] == "sim-42.7"
    fresh = client.post("/v2/contact", json=PAIR, headers={"X-Request-ID": "bad id\"x"})
    assert fresh.headers["x-request-id"] != "bad id" and len(fresh.headers["x-request-id"]) == 32


# --------------------------------------------------------------------------- bad input

RAW_BAD = [
    ("NaN token", b'{"a": {"size": [NaN, 2, 2], "position": [0,0,0], "quaternion": [1,0,0,0]},'
     b' "b": {"size": [2,2,2], "position": [0,0,1.9], "quaternion": [1,0,0,0]}}', "a.size"),
    ("Infinity token", b'{"a": {"size": [2, 2, 2], "position": [Infinity,0,0], "quaternion":'
     b' [1,0,0,0]}, "b": {"size": [2,2,2], "position": [0,0,1.9], "quaternion": [1,0,0,0]}}',
     "a.position"),
    ("-Infinity token", b'{"a": {"size": [2, 2, 2], "position": [0,0,0], "quaternion":'
     b' [1,0,0,-Infinity]}, "b": {"size": [2,2,2], "position": [0,0,1.9], "quaternion":'
     b' [1,0,0,0]}}', "a.quaternion"),
    ("overflow 1e400", b'{"a": {"size": [2, 2, 2], "position": [0,0,0], "quaternion":'
     b' [1,0,0,0]}, "b": {"size": [2,2,2], "position": [0,0,1e400], "quaternion": [1,0,0,0]}}',
     "b.position"),
    ("huge integer", b'{"a": {"size": [2, 2, 2], "position": [0,0,0], "quaternion": [1,0,0,0]},'
     b' "b": {"size": [2,2,2], "position": [0,0,' + b"9" * 400 + b'], "quaternion": [1,0,0,0]}}',
     "b.position"),
    ("malformed JSON", b'{"a": {"size": [2, 2, 2]', "body"),
    ("not an object", b'[1, 2, 3]', "body"),
    ("empty body", b"", "body"),
]


@pytest.mark.parametrize("name,raw,field", RAW_BAD, ids=[r[0] for r in RAW_BAD])
def test_raw_bad_bodies_are_422(client, name, raw, field):
    response = client.post("/v2/contact", content=raw,
                           headers={"Content-Type": "application/json"})
    assert_error(response, 422, field, "invalid_input")


BAD = [
    ("NaN string", {"a_size": ["NaN", 2, 2]}, "a.size"),
    ("number as string", {"a_position": ["0", 0, 0]}, "a.position"),
    ("boolean as number", {"b_position": [True, 0, 0]}, "b.position"),
    ("null in vector", {"b_position": [None, 0, 0]}, "b.position"),
    ("size of 2", {"a_size": [2, 2]}, "a.size"),
    ("size of 4", {"a_size": [2, 2, 2, 2]}, "a.size"),
    ("position of 4", {"b_position": [0, 0, 1.9, 0]}, "b.position"),
    ("quaternion of 3", {"a_quaternion": [1, 0, 0]}, "a.quaternion"),
    ("matrix 2x3", {"b_euler": None, "b_matrix": [[1, 0, 0], [0, 1, 0]]}, "b.matrix"),
    ("matrix row of 2", {"b_euler": None, "b_matrix": [[1, 0], [0, 1, 0], [0, 0, 1]]},
     "b.matrix"),
    ("euler of 2", {"b_euler": [0.1, 0.2]}, "b.euler"),
    ("size zero", {"a_size": [2, 0, 2]}, "a.size"),
    ("size negative", {"b_size": [2, 2, -1]}, "b.size"),
    ("size too small", {"b_size": [2, 2, 1e-9]}, "b.size"),
    ("position too far", {"b_position": [0, 0, 1e12]}, "b.position"),
    ("zero quaternion", {"a_quaternion": [0, 0, 0, 0]}, "a.quaternion"),
    ("tiny quaternion", {"a_quaternion": [1e-9, 0, 0, 0]}, "a.quaternion"),
    ("scaled matrix", {"b_euler": None, "b_matrix": [[2, 0, 0], [0, 2, 0], [0, 0, 2]]},
     "b.matrix"),
    ("sheared matrix", {"b_euler": None, "b_matrix": [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]},
     "b.matrix"),
    ("reflection", {"b_euler": None, "b_matrix": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]},
     "b.matrix"),
    ("zero matrix", {"b_euler": None, "b_matrix": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]},
     "b.matrix"),
    ("unknown object", {"a_size": None, "a_object": "container45"}, "a.object"),
    ("object and size", {"a_object": "cube"}, "a"),
    ("neither object nor size", {"a_size": None}, "a"),
    ("no orientation", {"b_euler": None}, "b"),
    ("two orientations", {"a_euler": [0, 0, 0]}, "a"),
    ("unknown body key", {"a_velocity": [0, 0, 0]}, "a.velocity"),
    ("missing position", {"b_position": None}, "b.position"),
    ("unknown mode", {"mode": "fastest"}, "mode"),
    ("unknown include", {"include": ["everything"]}, "include"),
    ("unknown euler convention", {"euler_convention": "zxz"}, "euler_convention"),
    ("unknown top-level key", {"c": {}}, "c"),
    ("missing body b", {"b": None}, "b"),
]


@pytest.mark.parametrize("name,changes,field", BAD, ids=[b[0] for b in BAD])
def test_bad_input_is_422_naming_the_field(client, name, changes, field):
    response = client.post("/v2/contact", json=pair(**changes))
    body = assert_error(response, 422, field, "invalid_input")
    assert all(d["reason"] for d in body["detail"])


def test_learned_modes_are_409_naming_the_mode(client):
    for mode in ("single", "committee", "auto"):
        response = client.post("/v2/contact", json=pair(mode=mode))
        body = assert_error(response, 409, "mode", "mode_unavailable")
        assert body["mode"] == mode and "bundle" in body["message"]


def test_wrong_content_type_is_415(client):
    response = client.post("/v2/contact", content=b"a=1",
                           headers={"Content-Type": "text/plain"})
    assert_error(response, 415, None, "unsupported_media_type")


def test_invalid_utf8_is_malformed_json(client):
    response = client.post("/v2/contact", content=b'{"a": "\xff\xfe"}',
                           headers={"Content-Type": "application/json"})
    assert_error(response, 422, "body", "invalid_input")


def test_unknown_object_without_scene(make_client):
    c = make_client(scene="")
    response = c.post("/v2/contact", json=pair(a_size=None, a_object="cube"))
    body = assert_error(response, 422, "a.object")
    assert "no scene" in body["detail"][0]["reason"]
    assert c.post("/v2/contact", json=PAIR).status_code == 200


def test_method_and_path_errors_use_the_envelope(client):
    assert_error(client.get("/v2/contact"), 405, None, "method_not_allowed")
    assert_error(client.get("/v1/nothing"), 404, None, "not_found")
