"""Issue 23, item 8: a JSON object that names a key twice is refused, naming the key.

Reproducer: ``"position": [NaN, 0, 0], "position": [0, 0, 0]`` was accepted (200): the parser
kept the last value, so the first was never validated.
"""
from __future__ import annotations

import orjson
import pytest

from tests.service.conftest import PAIR, assert_error
from tests.service.test_batch import as_json, poses

JSON = {"Content-Type": "application/json"}
B = b'"b":{"size":[2,2,2],"position":[0,0,1.9],"quaternion":[1,0,0,0]}'

DUPLICATES = [
    ("nan shadowed", b'{"a":{"size":[2,2,2],"position":[NaN,0,0],"position":[0,0,0],'
     b'"quaternion":[1,0,0,0]},' + B + b"}", "a.position"),
    ("orientation twice", b'{"a":{"size":[2,2,2],"position":[0,0,0],"quaternion":[1,0,0,0],'
     b'"quaternion":[0,1,0,0]},' + B + b"}", "a.quaternion"),
    ("top-level mode", b'{"mode":"exact","a":{"size":[2,2,2],"position":[0,0,0],'
     b'"quaternion":[1,0,0,0]},' + B + b',"mode":"exact"}', "mode"),
    ("body twice", b'{"a":{"size":[2,2,2],"position":[0,0,0],"quaternion":[1,0,0,0]},'
     + B + b"," + B + b"}", "b"),
    ("escaped key", b'{"a":{"size":[2,2,2],"position":[0,0,0],"quaternion":[1,0,0,0],'
     b'"quatern\\u0069on":[0,1,0,0]},' + B + b"}", "a.quaternion"),
]


@pytest.mark.parametrize("name,raw,field", DUPLICATES, ids=[d[0] for d in DUPLICATES])
def test_duplicate_keys_in_a_pair_are_422(client, name, raw, field):
    answer = assert_error(client.post("/v2/contact", content=raw, headers=JSON), 422, field,
                          "invalid_input")
    assert answer["detail"][0]["type"] == "duplicate_key"


def test_colons_inside_strings_are_not_keys(client):
    """The count of colons is only the fast path: a name with a colon is no duplicate."""
    raw = orjson.dumps(PAIR | {"mode": "exact"}).replace(b'"mode":"exact"',
                                                         b'"euler_convention":"zyx"')
    assert client.post("/v2/contact", content=raw, headers=JSON).status_code == 200
    named = orjson.dumps({"a": {"object": "no:such:object", **{k: v for k, v in PAIR["a"].items()
                                                             if k != "size"}}, "b": PAIR["b"]})
    assert_error(client.post("/v2/contact", content=named, headers=JSON), 422, "a.object")


@pytest.mark.parametrize("layout", ["simple", "parsed whole"])
def test_duplicate_columns_in_a_batch_are_422(client, layout):
    body = orjson.dumps(as_json(poses(3, seed=2)))
    extra = b',"a_position":[0,0,0]'
    if layout == "parsed whole":  # an escaped character: the body is parsed at once
        extra += b',"euler_convention":"zy\\u0078"'
    raw = body[:-1] + extra + b"}"
    answer = assert_error(client.post("/v2/contact/batch", content=raw, headers=JSON), 422,
                          "a_position", "invalid_input")
    assert answer["detail"][0]["type"] == "duplicate_key"
    assert client.post("/v2/contact/batch", content=body[:-1] + extra[21:] + b"}",
                       headers=JSON).status_code == 200  # the same without the duplicate


def test_duplicate_keys_in_a_reload_body_are_422(make_client):
    client = make_client(admin_token="token")
    response = client.post("/v1/admin/reload", content=b'{"bundle":"x","bundle":"y"}',
                           headers=JSON | {"Authorization": "Bearer token"})
    assert_error(response, 422, "bundle", "invalid_input")


@pytest.mark.parametrize("raw", [
    b'{"a":{' + b",".join(b'"\\x%d":0' % i for i in range(40)) + b"}}",  # invalid escapes
    b'{"a":{' + b",".join(b'"\xff%d":0' % i for i in range(40)) + b"}}",  # invalid UTF-8
    b'{"a":' + b'{"k":0,' * 30 + b"}",  # unbalanced
])
def test_too_many_keys_in_malformed_json_is_422(client, raw):
    assert_error(client.post("/v2/contact", content=raw, headers=JSON), 422, None,
                 "invalid_input")
