"""Issue #31, items 1, 2, 9, 10 and 12: inline geometry is data, bounded before it is built.

* a mesh in a request is base64 data, never a server path, and no message tells whether a path
  exists;
* every count of the part format is refused past its limit with 413 ``geometry_too_large``
  naming the field and the limit (a setting that GET /v1/models lists), before any hull is
  built, and the refusal is counted by limit in /metrics;
* huge integers and the documented position limit with parts answer, never 500;
* an inline body of many parts (up to the documented 128) is served.
"""
from __future__ import annotations

import base64
import struct

import pytest

from impactnet.models.compound import hull as hull_module
from tests.service.conftest import assert_error

LEVEL = [1.0, 0.0, 0.0, 0.0]


def _inline(*parts, position=(0.0, 0.0, 0.0)) -> dict:
    return {"parts": list(parts), "position": list(position), "quaternion": LEVEL}


def _box_body(z: float = 0.79) -> dict:
    return {"size": [1.0, 1.0, 1.0], "position": [0.0, 0.0, z], "quaternion": LEVEL}


def _stl(vertex_value: float = 0.0) -> str:
    """A binary STL tetrahedron (base64), one vertex coordinate set to ``vertex_value``."""
    corners = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    data = b"\0" * 80 + struct.pack("<I", len(faces))
    for face in faces:
        points = [list(corners[k]) for k in face]
        if 3 in face:
            points[face.index(3)][2] = 1.0 + vertex_value
        data += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *p) for p in points)
        data += b"\0\0"
    return base64.b64encode(data).decode()


@pytest.fixture
def detail(make_client):
    return make_client(scene="quay_crane_detail")


@pytest.mark.parametrize("path", ["/etc/passwd", "/etc/shadow", "/no/such/file.stl",
                                  "../../../etc/passwd", "lid.stl"])
def test_a_mesh_naming_a_server_path_is_refused_the_same_way_whether_it_exists(client, path):
    body = {"a": _inline({"name": "m", "mesh": path}), "b": _box_body()}
    answer = assert_error(client.post("/v2/contact", json=body), 422, field="a.parts[0].mesh")
    assert answer["message"] == ("a.parts[0].mesh: a mesh here is data: {format, data} with "
                                 "the file's bytes in base64; file names are not accepted")


@pytest.mark.parametrize("part, field, limit", [
    ({"name": "f", "frustum": {"sides": 5000, "base": 0.5, "height": 0.3}},
     "a.parts[0].frustum.sides", "max_frustum_sides"),
    ({"name": "f", "frustum": {"sides": 100_000_000, "base": 0.5, "height": 0.3}},
     "a.parts[0].frustum.sides", "max_frustum_sides"),
    ({"name": "h", "points": [[0.001 * k, 0.0, (k % 7) * 0.001] for k in range(1025)]},
     "a.parts[0].points", "max_hull_points"),
    ({"name": "p", "prism": {"section": [[0, 0]] * 257, "height": 0.1}},
     "a.parts[0].prism.section", "max_section_points"),
    ({"name": "m", "mesh": {"format": "stl", "data": "A" * 70_000}},
     "a.parts[0].mesh.data", "max_mesh_bytes"),
    ({"name": "n" * 65, "box": {"size": [0.1, 0.1, 0.1]}}, "a.parts[0].name",
     "part_name_chars"),
])
def test_a_count_past_its_limit_is_413_naming_the_field_before_any_hull(
        make_client, monkeypatch, part, field, limit):
    client = make_client(max_pair_body_bytes=1 << 20)
    monkeypatch.setattr(hull_module, "_merged_faces", _no_hull)
    response = client.post("/v2/contact", json={"a": _inline(part), "b": _box_body()})
    answer = assert_error(response, 413, field=field, error="geometry_too_large")
    assert answer["limit"] == limit and limit in answer["message"]
    metrics = client.get("/metrics").text
    assert f'impactnet_http_rejected_total{{reason="{limit}"}} 1.0' in metrics


def _no_hull(*args, **kwargs):
    raise AssertionError("a hull was built for a request past its limits")


def test_too_many_parts_and_too_many_corners_are_413(make_client):
    client = make_client(max_inline_parts=4, max_inline_vertices=40)
    boxes = [{"name": f"b{k}", "box": {"size": [0.1, 0.1, 0.1], "centre": [k * 0.2, 0, 0]}}
             for k in range(5)]
    answer = assert_error(client.post("/v2/contact", json={"a": _inline(*boxes),
                                                           "b": _box_body(3.0)}), 413)
    assert answer["limit"] == "max_inline_parts"
    frustum = {"name": "f", "frustum": {"sides": 16, "base": 0.2, "height": 0.1}}
    both = {"a": _inline(frustum), "b": _inline({**frustum, "name": "g"}, position=(0, 0, 2))}
    answer = assert_error(client.post("/v2/contact", json=both), 413, field="b.parts")
    assert answer["limit"] == "max_inline_vertices"  # 32 + 32 corners: the request's total


def test_the_limits_are_listed_with_the_caps(client):
    limits = client.get("/v1/models").json()["limits"]
    for name in ("max_inline_parts", "max_frustum_sides", "max_hull_points",
                 "max_section_points", "max_mesh_bytes", "max_mesh_vertices", "max_mesh_faces",
                 "max_inline_vertices", "max_candidates_per_pose", "max_candidates_per_request",
                 "max_part_contacts_per_pose", "max_part_contacts_per_batch",
                 "max_shape_pairs_per_request", "compute_deadline_s"):
        assert limits[name] > 0, name


def test_an_inline_body_s_hulls_are_built_off_the_event_loop(client, monkeypatch):
    """Regression: asking whether a single pair is two boxes read the shapes' bounding spheres,
    which built a 256-sided frustum's hull on the event loop (/healthz stalled 130 ms)."""
    import asyncio

    built = []

    def on_loop() -> bool:
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            return False
        return True

    make = hull_module._make
    monkeypatch.setattr(hull_module, "_make", lambda *a: built.append(on_loop()) or make(*a))
    frustum = {"name": "f", "frustum": {"sides": 256, "base": 0.5, "height": 0.3}}
    response = client.post("/v2/contact", json={"a": _inline(frustum), "b": _box_body(0.79)})
    assert response.status_code == 200, response.text
    assert built and not any(built)


def test_an_inline_body_of_many_parts_is_served(client):
    boxes = [{"name": f"b{k}", "box": {"size": [0.05, 0.05, 0.05],
                                       "centre": [0.1 * (k % 10), 0.1 * (k // 10), 0.0]}}
             for k in range(128)]
    response = client.post("/v2/contact", json={"a": _inline(*boxes), "b": _box_body(0.52)})
    assert response.status_code == 200, response.text
    assert response.json()["colliding"] is True


def test_an_stl_with_a_non_finite_vertex_is_422_naming_the_field(client):
    body = {"a": _inline({"name": "m", "mesh": {"format": "stl", "data": _stl(float("nan"))}}),
            "b": _box_body(2.0)}
    answer = assert_error(client.post("/v2/contact", json=body), 422, field="a.parts[0].mesh")
    assert "not finite" in answer["message"]
    fine = {"a": _inline({"name": "m", "mesh": {"format": "stl", "data": _stl()}}),
            "b": _box_body(2.0)}
    assert client.post("/v2/contact", json=fine).status_code == 200


@pytest.mark.parametrize("data", [base64.b64encode(b"solid x\nfacet garbage").decode(),
                                  base64.b64encode(b"\0" * 84).decode()])
def test_a_mesh_that_does_not_load_says_so_plainly(client, data):
    body = {"a": _inline({"name": "m", "mesh": {"format": "stl", "data": data}}),
            "b": _box_body(2.0)}
    answer = assert_error(client.post("/v2/contact", json=body), 422, field="a.parts[0].mesh")
    assert "base64" not in answer["message"] and "object" not in answer["message"]


@pytest.mark.parametrize("raw", [
    b'{"a": {"parts": [{"name": "b", "box": {"size": [1' + b"0" * 310 + b', 1, 1]}}], '
    b'"position": [0, 0, 0], "quaternion": [1, 0, 0, 0]}, "b": {"size": [1, 1, 1], '
    b'"position": [0, 0, 3], "quaternion": [1, 0, 0, 0]}}',
    b'{"a": {"parts": [{"name": "p", "points": [[1' + b"0" * 400 + b', 0, 0], [0, 1, 0], '
    b'[0, 0, 1], [0, 0, 0]]}], "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]}, '
    b'"b": {"size": [1, 1, 1], "position": [0, 0, 3], "quaternion": [1, 0, 0, 0]}}',
    b'{"a": {"parts": [{"name": "f", "frustum": {"sides": 8, "base": 1' + b"0" * 320
    + b', "height": 0.3}}], "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]}, '
    b'"b": {"size": [1, 1, 1], "position": [0, 0, 3], "quaternion": [1, 0, 0, 0]}}',
])
def test_a_huge_integer_in_a_part_is_422_not_500(client, raw):
    response = client.post("/v2/contact", content=raw,
                           headers={"Content-Type": "application/json"})
    assert_error(response, 422)
    assert len(response.content) < 2000  # the number is described, not echoed


def test_bodies_with_parts_at_the_position_limit_are_answered(detail):
    at = lambda x, z: {"object": "container40", "position": [x, 0.0, z], "quaternion": LEVEL}  # noqa: E731
    for x in (1e9, -1e9):
        pair = detail.post("/v2/contact", json={"a": at(x, 0.0), "b": at(x, 2.589)})
        assert pair.status_code == 200 and pair.json()["colliding"], pair.text
    batch = detail.post("/v2/contact/batch", json={
        "a_object": "container40", "b_object": "container40", "a_position": [1e9, 0, 0],
        "b_position": [1e9, 0, 2.589], "a_quaternion": LEVEL, "b_quaternion": LEVEL})
    assert batch.status_code == 200 and batch.json()["colliding"] == [True]
    part_beyond = _inline({"name": "b", "box": {"size": [1, 1, 1], "centre": [5, 0, 0]}},
                          position=(1e9, 0, 0))  # its part's centre lies 5 m past the limit
    long_box = {"size": [12.0, 1.0, 1.0], "position": [1e9, 0, 0.99], "quaternion": LEVEL}
    answer = detail.post("/v2/contact", json={"a": part_beyond, "b": long_box})
    assert answer.status_code == 200 and answer.json()["colliding"], answer.text


def test_an_unknown_object_names_the_scene_bodies(detail):
    response = detail.post("/v2/contact", json={
        "a": {"object": "nope", "position": [0, 0, 0], "quaternion": LEVEL}, "b": _box_body()})
    answer = assert_error(response, 422, field="a.object")
    assert "container40" in answer["message"] and "spreader" in answer["message"]


def test_models_shows_no_server_path(make_client):
    client = make_client(scene="quay_crane_detail", bundle=None)
    text = client.get("/v1/models").text
    assert "/models/bundles" not in text and "\\\\" not in text
