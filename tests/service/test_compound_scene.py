"""A scene with compound bodies is served (exact mode), and its compound objects are refused
by the box endpoints with a 422 that names the field and says why."""
from tests.service.conftest import assert_error, pair

IDENTITY = [1.0, 0.0, 0.0, 0.0]


def test_the_detailed_scene_serves_and_lists_its_compound_objects(make_client):
    client = make_client(scene="quay_crane_detail")
    assert client.get("/readyz").status_code == 200
    scene = client.get("/v1/models").json()["scene"]
    assert "container40" in scene["compound_objects"] and scene["objects"] == {}


def test_naming_a_compound_object_in_a_pair_is_a_422_naming_the_field(make_client):
    client = make_client(scene="quay_crane_detail")
    body = pair()
    body["b"] = {"object": "spreader", "position": [0, 0, 2.0], "quaternion": IDENTITY}
    answer = assert_error(client.post("/v1/contact", json=body), 422, field="b.object")
    assert "compound body" in answer["message"]


def test_naming_a_compound_object_in_a_batch_is_a_422_naming_the_column(make_client):
    client = make_client(scene="quay_crane_detail")
    batch = {"a_object": ["container40", "container40"], "a_position": [0, 0, 0],
             "a_quaternion": IDENTITY, "b_size": [1.0, 1.0, 1.0], "b_position": [0, 0, 2.0],
             "b_quaternion": IDENTITY}
    answer = assert_error(client.post("/v1/contact/batch", json=batch), 422, field="a_object")
    assert "compound body" in answer["message"]
