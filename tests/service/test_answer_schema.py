"""The OpenAPI document describes exactly the answers (issue #33, one answer shape): real answers
of box, compound and inline bodies, touching, apart within a margin and beyond it, single and
batched, are valid against the one schema that the document gives for each endpoint (its $refs
resolved); every object of it is closed (``additionalProperties: false``) and every property it
names is sent by one of them; the answer of the old shape is refused; JSON and npz batches carry
the same members."""
from __future__ import annotations

import base64
import io

import numpy as np
import pytest
from fastapi.testclient import TestClient

from impactnet.service.app import create_app
from tests.service.answer_paths import assert_same_answer, json_members
from tests.service.conftest import PAIR, test_settings

jsonschema = pytest.importorskip("jsonschema")

IDENTITY = [1.0, 0.0, 0.0, 0.0]
HEIGHT = 2.591  # a 40 ft container's height
#: The spreader's heads in a container's apertures, touching their flats; lifted 5 mm (apart).
SPREADER_ON, SPREADER_OFF = [0.0, 0.0045, HEIGHT / 2 + 0.405], [0.0, 0.0, HEIGHT / 2 + 0.41]
STACKED = [0.01, 0.0, HEIGHT - 0.001]
BOTH = ["manifold", "paper_angles"]
NPZ = "application/x-npz"
#: The answers' schemas in the document: (path, media type of the 200 answer).
SINGLE, BATCH = ("/v2/contact", "application/json"), ("/v2/contact/batch", "application/json")


@pytest.fixture(scope="module")
def box():
    with TestClient(create_app(test_settings())) as client:
        yield client


@pytest.fixture(scope="module")
def detail():
    with TestClient(create_app(test_settings(scene="quay_crane_detail"))) as client:
        yield client


def _resolved(node, components: dict):
    """``node`` with every ``#/components/schemas/...`` reference replaced by its schema."""
    if isinstance(node, list):
        return [_resolved(item, components) for item in node]
    if not isinstance(node, dict):
        return node
    if "$ref" in node:
        target = components[node["$ref"].rsplit("/", 1)[-1]]
        return _resolved(target, components) | {k: v for k, v in node.items() if k != "$ref"}
    return {key: _resolved(value, components) for key, value in node.items()}


def _schema(client: TestClient, where: tuple[str, str]) -> dict:
    document = client.app.openapi()
    answer = document["paths"][where[0]]["post"]["responses"]["200"]["content"][where[1]]
    return _resolved(answer["schema"], document["components"]["schemas"])


def _objects(schema, path: str = ""):
    """(path, object schema) of every object schema in a resolved schema."""
    if isinstance(schema, dict):
        if schema.get("type") == "object" or "properties" in schema:
            yield path, schema
        for key, value in schema.items():
            yield from _objects(value, f"{path}/{key}")
    elif isinstance(schema, list):
        for i, item in enumerate(schema):
            yield from _objects(item, f"{path}/{i}")


def _validate(schema: dict, answer: dict) -> None:
    jsonschema.Draft202012Validator.check_schema(schema)
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(answer), key=str)
    assert not errors, [f"{list(e.absolute_path)}: {e.message[:200]}" for e in errors[:5]]


def _body(name: str, position) -> dict:
    return {"object": name, "position": list(position), "quaternion": IDENTITY}


def _inline_parts() -> list[dict]:
    """A block and a mesh of two separate cubes (not convex: replaced by its hull, a note)."""
    trimesh = pytest.importorskip("trimesh")
    cubes = trimesh.util.concatenate([
        trimesh.creation.box(extents=(0.1, 0.1, 0.1)),
        trimesh.creation.box(extents=(0.1, 0.1, 0.1)).apply_translation((0.2, 0.0, 0.0))])
    buffer = io.BytesIO()
    cubes.export(buffer, file_type="stl")
    mesh = {"format": "stl", "data": base64.b64encode(buffer.getvalue()).decode()}
    return [{"name": "block", "box": {"size": [0.2, 0.2, 0.3], "centre": [0, 0, 0.1]}},
            {"name": "lid", "mesh": mesh}]


def _singles(box: TestClient, detail: TestClient) -> list[dict]:
    """Single answers: boxes touching, apart within the margin and beyond it; compound bodies
    touching and apart within the margin; a box against inline parts (with a note)."""
    apart = PAIR | {"b": PAIR["b"] | {"position": [0.0, 0.0, 2.5], "euler": [0.0, 0.0, 0.0]}}
    inline = {"a": {"size": [2.0, 2.0, 2.0], "position": [0, 0, 0], "quaternion": IDENTITY},
              "b": {"parts": _inline_parts(), "position": [0, 0, 1.049],
                    "quaternion": IDENTITY}, "include": BOTH}
    posts = [(box, PAIR | {"include": BOTH}), (box, apart | {"margin": 1.0}),
             (box, apart | {"include": BOTH}),
             (detail, {"a": _body("container40", [0, 0, 0]), "b": _body("spreader", SPREADER_ON),
                       "include": BOTH}),
             (detail, {"a": _body("container40", [0, 0, 0]),
                       "b": _body("spreader", SPREADER_OFF), "margin": 0.5, "include": BOTH}),
             (box, inline)]
    answers = []
    for client, body in posts:
        response = client.post("/v2/contact", json=body)
        assert response.status_code == 200, response.text
        answers.append(response.json())
    return answers


def _box_columns() -> dict:
    rng = np.random.default_rng(0)
    gaps = rng.uniform(-0.2, 1.0, 40)  # touching, within a 0.5 m margin and beyond it
    return {"a_size": [1.0, 1.0, 1.0], "a_position": [0, 0, 0], "a_quaternion": IDENTITY,
            "b_size": [1.0, 1.0, 1.0], "b_position": [[1.0 + g, 0.1, 0.0] for g in gaps],
            "b_euler": rng.uniform(-0.05, 0.05, (40, 3)).tolist()}


def _compound_columns() -> dict:
    return {"a_object": "container40", "a_position": [0, 0, 0], "a_quaternion": IDENTITY,
            "b_object": ["container40", "spreader", "spreader", "spreader"],
            "b_position": [STACKED, SPREADER_ON, SPREADER_OFF, [0, 0, 50.0]],
            "b_quaternion": IDENTITY}


def _batches(box: TestClient, detail: TestClient, accept: str = "application/json"):
    """(JSON or npz answer) of a box batch and a compound batch, both with a 0.5 m margin."""
    out = []
    for client, columns in ((box, _box_columns()), (detail, _compound_columns())):
        response = client.post("/v2/contact/batch?margin=0.5", json=columns | {"include": BOTH},
                               headers={"Accept": accept})
        assert response.status_code == 200, response.text
        if accept == NPZ:
            with np.load(io.BytesIO(response.content), allow_pickle=False) as npz:
                out.append({name: npz[name] for name in npz.files})
        else:
            out.append(response.json())
    return out


def test_every_object_of_the_answer_schemas_is_closed(box):
    for where in (SINGLE, BATCH):
        objects = list(_objects(_schema(box, where)))
        assert len(objects) >= 4, where
        for path, schema in objects:
            assert schema.get("additionalProperties") is False, (where, path)


def test_the_distance_and_the_closest_points_are_always_sent_and_may_be_null(box):
    for where in (SINGLE, BATCH):
        schema = _schema(box, where)
        assert {"distance", "closest_a", "closest_b", "contacts"} <= set(schema["required"])
    single = _schema(box, SINGLE)["properties"]
    for key in ("distance", "closest_a", "closest_b", "paper_angles"):
        assert {"type": "null"} in single[key]["anyOf"], key


def test_single_answers_of_every_kind_of_body_are_valid_against_one_schema(box, detail):
    schema = _schema(box, SINGLE)
    assert schema == _schema(detail, SINGLE)  # one document whatever the scene
    answers = _singles(box, detail)
    for answer in answers:
        _validate(schema, answer)
    touching, within, beyond, compound, compound_apart, inline = answers
    assert len(touching["contacts"]) == 1 and touching["contacts"][0]["part_a"] == "box"
    assert within["distance"] > 0 and within["closest_a"] is not None
    assert beyond["distance"] is None and beyond["paper_angles"] is None
    assert compound["predictor"] == "oracle" and len(compound["contacts"]) == 4
    assert compound_apart["closest_b"] is not None and compound_apart["contacts"] == []
    assert inline["warnings"] and inline["contacts"][0]["part_b"] in ("block", "lid")


def test_batch_answers_of_box_and_compound_bodies_are_valid_against_one_schema(box, detail):
    schema = _schema(box, BATCH)
    boxes, compound = _batches(box, detail)
    for answer in (boxes, compound):
        _validate(schema, answer)
    for answer in (boxes, compound):  # touching, within the margin and beyond it
        assert None in answer["distance"] and None in answer["closest_a"]
        assert any(d is not None and d > 0 for d in answer["distance"])
        assert any(d is not None and d < 0 for d in answer["distance"])
    assert compound["contacts"]["offsets"][:3] == [0, 40, 44]


def _properties(schema, path: tuple = ()) -> set[tuple]:
    """Every property path a resolved schema names (array items and nullable values
    looked through)."""
    out: set[tuple] = set()
    for option in schema.get("anyOf", []):
        out |= _properties(option, path)
    if "items" in schema:
        out |= _properties(schema["items"], path)
    for key, value in schema.get("properties", {}).items():
        out |= {(*path, key)} | _properties(value, (*path, key))
    return out


def _sent(answer, path: tuple = ()) -> set[tuple]:
    """Every key path of an answer (lists looked through)."""
    out: set[tuple] = set()
    if isinstance(answer, list):
        for item in answer:
            out |= _sent(item, path)
    elif isinstance(answer, dict):
        for key, value in answer.items():
            out |= {(*path, key)} | _sent(value, (*path, key))
    return out


def test_every_property_the_schemas_name_is_sent(box, detail):
    """A documented key that no answer carries is drift too (the validation alone allows
    it: optional keys may be absent)."""
    singles = set().union(*(_sent(a) for a in _singles(box, detail)))
    assert _properties(_schema(box, SINGLE)) == singles
    batches = set().union(*(_sent(a) for a in _batches(box, detail)))
    assert _properties(_schema(box, BATCH)) == batches


def test_the_answer_of_the_old_shape_is_refused(box):
    validator = jsonschema.Draft202012Validator(_schema(box, BATCH))
    answer = box.post("/v2/contact/batch", json=_box_columns()).json()
    assert validator.is_valid(answer)
    old = answer | {"feature_a": answer["feature_a"]["id"], "axis": answer["contacts"]["axis"]}
    assert not validator.is_valid(old)
    single = jsonschema.Draft202012Validator(_schema(box, SINGLE))
    one = box.post("/v2/contact", json=PAIR).json()
    assert single.is_valid(one)
    assert not single.is_valid(one | {"axis": one["contacts"][0]["axis"]})
    assert not single.is_valid({k: v for k, v in one.items() if k != "distance"})


def test_json_and_npz_batches_carry_the_same_members(box, detail):
    texts, binaries = _batches(box, detail), _batches(box, detail, accept=NPZ)
    for text, binary in zip(texts, binaries, strict=True):
        assert set(json_members(text)) == set(binary)
        assert {"feature_a_name", "contact_offsets", "contact_contact_type",
                "contact_feature_b_kind", "contact_manifold_points", "n", "mode",
                "model_version"} <= set(binary)
        assert_same_answer(text, binary)


def test_a_frame_answers_each_pair_in_the_one_shape_with_its_body_ids(detail):
    """A frame's pairs are valid against the frame's schema, whose pair is the single answer's
    pair level plus the two ids; the pair answers what POST /v2/contact answers for it."""
    bodies = [{"id": "c0"} | _body("container40", [0, 0, 0]),
              {"id": "s1"} | _body("spreader", SPREADER_ON),
              {"id": "far"} | _body("container40", [0, 30.0, 0])]
    response = detail.post("/v2/frame", json={"bodies": bodies, "margin": 0.5,
                                              "include": BOTH})
    assert response.status_code == 200, response.text
    frame = response.json()
    _validate(_schema(detail, ("/v2/frame", "application/json")), frame)
    assert [(p["a"], p["b"]) for p in frame["pairs"]] == [("c0", "s1")]
    single = detail.post("/v2/contact", json={"a": _body("container40", [0, 0, 0]),
                                              "b": _body("spreader", SPREADER_ON),
                                              "margin": 0.5, "include": BOTH}).json()
    pair = {k: v for k, v in frame["pairs"][0].items() if k not in ("a", "b")}
    assert pair == {k: v for k, v in single.items()
                    if k not in ("mode", "model_version", "warnings")}
