"""Compound bodies through the HTTP API: the detailed scene is served; a pair or a batch that
names a compound object is answered by the exact compound oracle in the one answer shape: the
body level (the summary, with the deepest part contact's type, features and parts) and the part
contacts (ragged in batches, JSON and npz); the caps refuse with a 413."""
import base64
import io

import numpy as np
import pytest

from impactnet.models.compound import compound_answer
from impactnet.models.scenes import load_scene
from tests.service.conftest import assert_error

IDENTITY = [1.0, 0.0, 0.0, 0.0]
HEIGHT = 2.591
#: Spreader frame's centre above a 40 ft container's centre with the heads in the apertures,
#: nudged 4.5 mm across: each head touches its aperture's flat by 0.75 mm.
SPREADER_AT = [0.0, 0.0045, HEIGHT / 2 + 0.4 + 0.005]
STACKED_AT = [0.01, 0.0, HEIGHT - 0.001]


@pytest.fixture
def detail(make_client):
    return make_client(scene="quay_crane_detail")


def _body(name, position):
    return {"object": name, "position": position, "quaternion": IDENTITY}


def test_the_detailed_scene_serves_and_lists_its_compound_objects(detail):
    assert detail.get("/readyz").status_code == 200
    scene = detail.get("/v1/models").json()["scene"]
    assert "container40" in scene["compound_objects"] and scene["objects"] == {}


def test_a_compound_pair_is_answered_by_the_oracle_with_its_part_contacts(detail):
    answer = detail.post("/v2/contact", json={
        "a": _body("container40", [0, 0, 0]), "b": _body("container40", STACKED_AT),
        "mode": "exact"}).json()
    assert answer["predictor"] == "oracle" and answer["mode"] == "exact"
    parts = load_scene("quay_crane_detail").body("container40").parts
    reference = compound_answer(parts, [0, 0, 0], IDENTITY, parts, STACKED_AT, IDENTITY)
    np.testing.assert_allclose(answer["depth"], reference.summary.depth[0], rtol=1e-12)
    np.testing.assert_allclose(answer["point"], reference.summary.point[0], atol=1e-12)
    assert answer["distance"] == -answer["depth"] and answer["closest_a"] is None
    assert len(answer["contacts"]) == 40 == answer["cluster_size"]
    first = answer["contacts"][0]
    assert first["part_a"].startswith("casting_top_") and first["contact_type"] == "face-face"
    assert set(first) == {"part_a", "part_b", "point", "normal", "depth", "contact_type",
                          "feature_a", "feature_b", "axis", "pressure"}
    assert first["axis"] == -1  # a convex part (a casting's ring) has no box axis
    assert set(first["feature_a"]) == {"id", "name", "kind"}
    # the body level names the deepest part contact: the first
    assert answer["contact_type"] == first["contact_type"]
    assert answer["feature_a"] == {"part": first["part_a"], **first["feature_a"]}
    assert answer["feature_b"] == {"part": first["part_b"], **first["feature_b"]}
    assert [c["depth"] for c in answer["contacts"]] == sorted(
        (c["depth"] for c in answer["contacts"]), reverse=True)


def test_a_learned_mode_without_a_bundle_is_409_for_a_compound_pair_as_for_a_box_pair(detail):
    body = {"a": _body("container40", [0, 0, 0]), "b": _body("container40", STACKED_AT),
            "mode": "single"}
    answer = assert_error(detail.post("/v2/contact", json=body), 409, "mode",
                          "mode_unavailable")
    assert answer["mode"] == "single"


def _batch():
    return {"a_object": "container40", "a_position": [0, 0, 0], "a_quaternion": IDENTITY,
            "b_object": ["container40", "spreader", "spreader"],
            "b_position": [STACKED_AT, SPREADER_AT, [0, 0, HEIGHT / 2 + 0.405]],
            "b_quaternion": IDENTITY}


def test_a_batch_answers_the_ragged_layout_in_json_and_npz_alike(detail):
    as_json = detail.post("/v2/contact/batch", json=_batch()).json()
    contacts = as_json["contacts"]
    assert as_json["n"] == 3 and contacts["offsets"] == [0, 40, 44, 44]
    assert contacts["part_b"][40:] == ["head_fl", "head_fr", "head_al", "head_ar"]
    assert as_json["colliding"] == [True, True, False]
    assert as_json["cluster_size"] == [40, 4, 0]
    assert as_json["feature_b"]["part"][:2] == [contacts["part_b"][0], contacts["part_b"][40]]
    assert as_json["feature_b"]["part"][2] is None and as_json["distance"][2] is None
    assert as_json["contact_type"][1] == contacts["contact_type"][40]
    binary = detail.post("/v2/contact/batch", json=_batch(),
                         headers={"accept": "application/x-npz"})
    with np.load(io.BytesIO(binary.content), allow_pickle=False) as npz:
        np.testing.assert_array_equal(npz["contact_offsets"], contacts["offsets"])
        np.testing.assert_array_equal(npz["contact_depth"], contacts["depth"])
        assert npz["contact_part_b"].tolist() == contacts["part_b"]
        assert npz["contact_contact_type"].tolist() == contacts["contact_type"]
        assert npz["contact_type"].tolist() == as_json["contact_type"]  # the body level's
        assert npz["feature_b_part"].tolist() == [p or "" for p in as_json["feature_b"]["part"]]
        assert npz["contact_feature_b_kind"].tolist() == contacts["feature_b"]["kind"]


def test_part_contacts_over_the_caps_are_413_naming_the_cap(make_client):
    per_pose = make_client(scene="quay_crane_detail", max_part_contacts_per_pose=39)
    answer = assert_error(per_pose.post("/v2/contact", json={
        "a": _body("container40", [0, 0, 0]), "b": _body("container40", STACKED_AT)}), 413,
        error="too_many_part_contacts")
    assert "max_part_contacts_per_pose" in answer["message"]
    per_batch = make_client(scene="quay_crane_detail", max_part_contacts_per_batch=43)
    answer = assert_error(per_batch.post("/v2/contact/batch", json=_batch()), 413,
                          error="too_many_part_contacts")
    assert "max_part_contacts_per_batch" in answer["message"]


def test_an_unknown_object_in_the_detailed_scene_is_still_a_422(detail):
    body = {"a": _body("container45", [0, 0, 0]), "b": _body("container40", STACKED_AT)}
    assert_error(detail.post("/v2/contact", json=body), 422, field="a.object")


def _inline_pair(parts):
    return {"a": {"size": [2.0, 2.0, 2.0], "position": [0, 0, 0], "quaternion": IDENTITY},
            "b": {"parts": parts, "position": [0, 0, 1.049], "quaternion": IDENTITY}}


def test_a_compound_body_given_inline_is_answered_and_its_mesh_becomes_its_hull(client):
    trimesh = pytest.importorskip("trimesh")
    buffer = io.BytesIO()
    trimesh.creation.box(extents=(0.3, 0.3, 0.1)).export(buffer, file_type="stl")
    data = base64.b64encode(buffer.getvalue()).decode()
    answer = client.post("/v2/contact", json=_inline_pair([
        {"name": "block", "box": {"size": [0.2, 0.2, 0.3], "centre": [0, 0, 0.1]}},
        {"name": "lid", "mesh": {"format": "stl", "data": data}}])).json()
    assert answer["predictor"] == "oracle"
    assert [c["part_b"] for c in answer["contacts"]] == ["lid"]
    np.testing.assert_allclose(answer["depth"], 1e-3, atol=1e-7)  # the STL is float32


@pytest.mark.parametrize("part, field, reason", [
    ({"name": "x", "sphere": {"r": 1.0}}, "b.parts[1]", "unknown key"),
    ({"name": "flat", "points": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]}, "b.parts[1]",
     "flat"),
    ({"name": "lid", "mesh": {"format": "stl", "data": "@@@"}}, "b.parts[1].mesh.data",
     "base64"),
    ({"name": "lid", "mesh": {"format": "stl", "data": base64.b64encode(b"no mesh").decode()}},
     "b.parts[1].mesh", "fewer than 4 vertices"),  # trimesh reads junk as an empty mesh
    ({"name": "inner", "box": {"size": [0.01, 0.01, 0.01]}}, "b.parts[1]", "inside"),
])
def test_a_bad_inline_part_is_a_422_naming_its_field(client, part, field, reason):
    body = _inline_pair([{"name": "block", "box": {"size": [0.2, 0.2, 0.1]}}, part])
    answer = assert_error(client.post("/v2/contact", json=body), 422, field=field)
    assert reason in answer["message"]


def test_models_describes_every_body_with_its_parts(detail):
    bodies = detail.get("/v1/models").json()["scene"]["bodies"]
    spreader = bodies["spreader"]
    assert spreader["kind"] == "compound" and spreader["made_by"]["sides"] == 32
    heads = [p for p in spreader["parts"] if p["group"].startswith("head_")]
    assert len(heads) == 4 and all(p["kind"] == "convex" for p in heads)
    for part in spreader["parts"]:  # bounds inside the envelope
        assert all(lo >= e - 1e-9 for lo, e in zip(part["lo"], spreader["envelope"]["lo"]))
    container = bodies["container40"]
    assert container["made_by"]["detail"] == 2
    assert {p["group"] for p in container["parts"]} >= {"casting_top_fl", "casting_bottom_ar"}
    assert "quay_crane" in container["description"]  # the name means a box there


def test_models_describes_a_box_body_by_its_size(client):
    bodies = client.get("/v1/models").json()["scene"]["bodies"]
    assert bodies["container40"]["kind"] == "box"
    assert bodies["container40"]["size"] == [12.192, 2.438, 2.591]
    assert "quay_crane_detail" in bodies["container40"]["description"]
