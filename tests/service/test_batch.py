"""POST /v2/contact/batch: columnar JSON and npz in the one answer shape (per pair, and the ragged
part contacts), equal answers, the gap within a margin, bad columns (status first)."""
from __future__ import annotations

import io
import zipfile

import numpy as np
import orjson
import pytest

from impactnet.models.box.exact import box_box
from impactnet.models.geometry.rotations import quaternion_to_matrix, random_quaternions
from tests.service.answer_paths import assert_same_answer
from tests.service.conftest import assert_error

URL = "/v2/contact/batch"
NPZ = "application/x-npz"


def poses(n: int, seed: int = 0) -> dict:
    """N random cube pairs around contact, as request columns (arrays)."""
    rng = np.random.default_rng(seed)
    return {
        "a_size": np.array([2.0, 2.0, 2.0]),
        "a_position": rng.normal(size=(n, 3)),
        "a_quaternion": random_quaternions(n, rng),
        "b_size": rng.uniform(0.5, 3.0, size=(n, 3)),
        "b_position": rng.normal(size=(n, 3)) * 1.5,
        "b_quaternion": random_quaternions(n, rng),
    }


def as_json(columns: dict, **options) -> dict:
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in columns.items()} \
        | options


def npz_bytes(columns: dict, compressed: bool = False) -> bytes:
    buffer = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(
        buffer, **{k: np.asarray(v) for k, v in columns.items()})
    return buffer.getvalue()


def load_npz(data: bytes) -> dict:
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def test_json_batch_matches_exact_solver(client):
    columns = poses(500)
    response = client.post(URL, json=as_json(columns))
    assert response.status_code == 200
    body = response.json()
    expected = box_box(*(columns[k] for k in ("a_size", "a_position", "a_quaternion",
                                              "b_size", "b_position", "b_quaternion")))
    assert body["n"] == 500 and body["mode"] == "exact"
    assert body["model_version"] == response.headers["x-model-version"]
    # The service normalises quaternions once more than a direct call: ulp differences.
    np.testing.assert_allclose(body["point"], expected.point, rtol=0, atol=1e-12)
    np.testing.assert_allclose(body["normal"], expected.normal, rtol=0, atol=1e-12)
    np.testing.assert_allclose(body["depth"], expected.depth, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(body["colliding"], expected.colliding)
    assert body["contact_type"] == expected.contact_type.tolist()
    np.testing.assert_array_equal(body["feature_a"]["id"], expected.feature_a)
    np.testing.assert_array_equal(body["feature_b"]["id"], expected.feature_b)
    assert body["feature_a"]["part"] == ["box" if c else None for c in body["colliding"]]
    assert body["predictor"] == ["exact"] * 500
    assert "manifold_points" not in body["contacts"] and "paper_angles" not in body
    assert 0 < sum(body["colliding"]) < 500
    # one part contact per touching pair: the solver's own axis and pressure
    hit = expected.colliding
    np.testing.assert_array_equal(np.diff(body["contacts"]["offsets"]), hit.astype(int))
    np.testing.assert_array_equal(body["contacts"]["axis"], expected.axis[hit])
    np.testing.assert_allclose(body["contacts"]["depth"], expected.depth[hit], rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(body["contacts"]["pressure"], expected.pressure[hit], rtol=0,
                               atol=1e-12)
    assert body["contacts"]["part_a"] == ["box"] * int(hit.sum())


def test_binary_round_trip_equals_json(client):
    columns = poses(300, seed=1)
    as_text = client.post(URL, json=as_json(columns, include=["manifold", "paper_angles"]))
    as_npz = client.post(URL + "?include=manifold&include=paper_angles",
                         content=npz_bytes(columns),
                         headers={"Content-Type": NPZ, "Accept": NPZ})
    assert as_text.status_code == 200 and as_npz.status_code == 200
    assert as_npz.headers["content-type"] == NPZ
    text, binary = as_text.json(), load_npz(as_npz.content)
    assert_same_answer(text, binary)  # every member, every value
    assert "contact_manifold_points" in binary and "paper_angles" in binary
    assert None in text["paper_angles"] and np.isnan(binary["paper_angles"]).any()
    assert binary["point"].dtype == np.dtype("<f8") and binary["colliding"].dtype == bool
    assert binary["contact_type"].tolist() == text["contact_type"]
    assert binary["feature_a_name"].tolist() == text["feature_a"]["name"]
    assert str(binary["model_version"]) == text["model_version"]


@pytest.mark.parametrize("request_type,answer_type", [("json", NPZ), (NPZ, "json")])
def test_mixed_media_types(client, request_type, answer_type):
    columns = poses(20, seed=2)
    if request_type == "json":
        response = client.post(URL, json=as_json(columns), headers={"Accept": answer_type})
    else:
        response = client.post(URL, content=npz_bytes(columns, compressed=True),
                               headers={"Content-Type": NPZ, "Accept": "application/json"})
    assert response.status_code == 200
    depth = (load_npz(response.content)["depth"] if answer_type == NPZ
             else np.asarray(response.json()["depth"]))
    assert depth.shape == (20,)


def test_broadcast_objects_matrices_and_euler(client):
    n = 50
    rng = np.random.default_rng(3)
    q = random_quaternions(n, rng)
    body = {"a_object": "container40", "a_position": [0, 0, 0], "a_euler": [0, 0, 0],
            "b_object": ["spreader", "container20"] * (n // 2),
            "b_position": (rng.normal(size=(n, 3)) + [0, 0, 2.0]).tolist(),
            "b_matrix": quaternion_to_matrix(q).tolist()}
    response = client.post(URL, json=body)
    assert response.status_code == 200
    sizes = np.array([[12.0, 2.35, 0.8], [6.058, 2.438, 2.591]] * (n // 2))
    expected = box_box([12.192, 2.438, 2.591], [0, 0, 0], [1, 0, 0, 0], sizes,
                       body["b_position"], q)
    np.testing.assert_allclose(response.json()["point"], expected.point, atol=1e-9)


def test_options_in_query_string_for_json(client):
    response = client.post(URL + "?include=manifold", json=as_json(poses(3)))
    assert response.status_code == 200 and "manifold_points" in response.json()["contacts"]
    both = client.post(URL + "?mode=exact", json=as_json(poses(3), mode="exact"))
    assert_error(both, 422, "mode")


def _apart(gaps) -> dict:
    """Unit cubes side by side along x, their faces ``gaps`` apart (metres)."""
    return {"a_size": [1.0, 1.0, 1.0], "a_position": [0, 0, 0], "a_quaternion": [1, 0, 0, 0],
            "b_size": [1.0, 1.0, 1.0], "b_position": [[1.0 + g, 0, 0] for g in gaps],
            "b_quaternion": [1, 0, 0, 0]}


def test_a_margin_in_the_body_or_the_query_answers_the_gaps_within_it(client):
    columns = _apart([-0.01, 0.2, 0.6])
    text = client.post(URL, json=columns | {"margin": 0.5}).json()
    np.testing.assert_allclose(text["distance"][:2], [-0.01, 0.2], rtol=0, atol=1e-12)
    assert text["distance"][2] is None  # beyond the margin
    assert text["closest_a"][0] is None and text["closest_a"][2] is None
    np.testing.assert_allclose(text["closest_a"][1], [0.5, 0, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(text["closest_b"][1], [0.7, 0, 0], rtol=0, atol=1e-12)
    assert text["feature_a"]["part"] == ["box", "box", None]
    binary = load_npz(client.post(URL + "?margin=0.5", content=npz_bytes(
        {k: np.asarray(v) for k, v in columns.items()}), headers={"Content-Type": NPZ,
                                                                  "Accept": NPZ}).content)
    assert_same_answer(text, binary)
    assert binary["distance"][2] == np.inf and np.isnan(binary["closest_b"][2]).all()
    assert_error(client.post(URL + "?margin=100.5", json=columns), 422, "margin")
    assert_error(client.post(URL, json=columns | {"margin": -1}), 422, "margin")


def test_the_documented_json_body_names_every_column_and_option_the_parser_accepts(client):
    """The OpenAPI document's BatchRequest (closed: additionalProperties false) and the NumPy
    parser accept the same keys (a `margin` missing from the document was drift)."""
    from impactnet.service.codecs.columns import COLUMNS, OPTIONS

    documented = client.get("/openapi.json").json()["components"]["schemas"]["BatchRequest"]
    assert documented["additionalProperties"] is False
    assert set(documented["properties"]) == set(COLUMNS) | set(OPTIONS)


def test_learned_mode_is_409(client):
    response = client.post(URL, json=as_json(poses(3), mode="committee"))
    body = assert_error(response, 409, "mode", "mode_unavailable")
    assert body["mode"] == "committee"
    assert_error(client.post(URL + "?mode=auto", content=npz_bytes(poses(2)),
                             headers={"Content-Type": NPZ}), 409, "mode")


# --------------------------------------------------------------------------- bad columns


def _with(**changes):
    body = as_json(poses(4, seed=5))
    for key, value in changes.items():
        if value is None:
            body.pop(key, None)
        else:
            body[key] = value
    return body


BAD = [
    ("ragged columns", {"a_position": [[0, 0, 0]] * 3}, "a_position", None),
    ("ragged rows", {"b_position": [[0, 0, 0], [0, 0], [0, 0, 0], [1, 1, 1]]}, "b_position",
     None),
    ("wrong width", {"a_quaternion": [[1, 0, 0]] * 4}, "a_quaternion", None),
    ("scalar position", {"a_position": 1.0}, "a_position", None),
    ("NaN string", {"b_size": [["NaN", 1, 1]] * 4}, "b_size", None),
    ("null", {"b_size": [[None, 1, 1]] * 4}, "b_size", None),
    ("booleans", {"b_position": [[True, False, True]] * 4}, "b_position", None),
    ("size zero", {"a_size": [[1, 1, 1], [1, 0, 1], [1, 1, 1], [1, 1, -2]]}, "a_size", [1, 3]),
    ("zero quaternion", {"b_quaternion": [[1, 0, 0, 0], [0, 0, 0, 0]] * 2}, "b_quaternion",
     [1, 3]),
    ("non-rotation matrix", {"b_quaternion": None, "b_matrix": [[[1, 0, 0], [0, 1, 0],
                                                                 [0, 0, 1]],
                                                                [[2, 0, 0], [0, 1, 0],
                                                                 [0, 0, 1]]] * 2},
     "b_matrix", [1, 3]),
    ("unknown object", {"a_size": None, "a_object": ["cube", "cube", "box9", "cube"]},
     "a_object", [2]),
    ("object not a string", {"a_size": None, "a_object": [1, 2, 3, 4]}, "a_object", None),
    ("object and size", {"a_object": "cube"}, "a_size", None),
    ("no orientation", {"a_quaternion": None}, "a_quaternion", None),
    ("two orientations", {"a_euler": [0, 0, 0]}, "a_quaternion", None),
    ("missing position", {"b_position": None}, "b_position", None),
    ("unknown column", {"c_size": [1, 1, 1]}, "c_size", None),
    ("unknown mode", {"mode": "fast"}, "mode", None),
    ("position out of range", {"a_position": [[0, 0, 2e9]] * 4}, "a_position", [0, 1, 2, 3]),
    ("empty batch", {"a_position": [], "b_position": []}, "a_position", None),
]


@pytest.mark.parametrize("name,changes,field,rows", BAD, ids=[b[0] for b in BAD])
def test_bad_columns_are_422_naming_column_and_rows(client, name, changes, field, rows):
    response = client.post(URL, json=_with(**changes))
    body = assert_error(response, 422, field, "invalid_input")
    if rows is not None:
        assert body["detail"][0]["rows"] == rows


@pytest.mark.parametrize("raw", [b"{", b"[1, 2]", b'{"a_size": [NaN, 1, 1]}', b"",
                                 b'{"a_position": [1e400, 0, 0]}'])
def test_malformed_json_is_422(client, raw):
    response = client.post(URL, content=raw, headers={"Content-Type": "application/json"})
    assert_error(response, 422, "body", "invalid_input")


def test_nan_in_npz_is_422_with_rows(client):
    columns = poses(5)
    columns["b_position"][2, 1] = np.nan
    columns["b_position"][4, 0] = np.inf
    response = client.post(URL, content=npz_bytes(columns), headers={"Content-Type": NPZ})
    body = assert_error(response, 422, "b_position")
    assert body["detail"][0]["rows"] == [2, 4]


@pytest.mark.parametrize("payload", [b"not a zip", b"PK\x03\x04broken", npz_bytes(poses(2))[:60]])
def test_malformed_npz_is_422(client, payload):
    response = client.post(URL, content=payload, headers={"Content-Type": NPZ})
    assert_error(response, 422, "body", "invalid_input")


def test_pickled_object_array_is_refused(client):
    buffer = io.BytesIO()
    columns = poses(2)
    columns["a_object"] = np.array([{"x": 1}, None], dtype=object)
    columns.pop("a_size")
    np.savez(buffer, **columns)  # allow_pickle is the default when saving
    response = client.post(URL, content=buffer.getvalue(), headers={"Content-Type": NPZ})
    assert_error(response, 422, "a_object")


def test_npz_that_expands_beyond_the_limit_is_413(make_client):
    c = make_client(max_body_bytes=64 * 1024)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        array = io.BytesIO()
        np.save(array, np.zeros((100_000, 3)))
        archive.writestr("a_position.npy", array.getvalue())
    assert len(buffer.getvalue()) < 64 * 1024
    response = c.post(URL, content=buffer.getvalue(), headers={"Content-Type": NPZ})
    assert_error(response, 413, None, "body_too_large")


def test_npz_member_shorter_than_its_header_is_422(client):
    array = io.BytesIO()
    np.save(array, np.zeros((1000, 3)))
    data = array.getvalue()
    header_end = data.index(b"\n") + 1
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("a_position.npy", data[:header_end] + b"\0" * 16)
    response = client.post(URL, content=buffer.getvalue(), headers={"Content-Type": NPZ})
    assert_error(response, 422, "body")


def test_batch_above_the_pair_limit_is_413(make_client):
    c = make_client(max_batch_pairs=10)
    response = c.post(URL, json=as_json(poses(11)))
    assert_error(response, 413, None, "batch_too_large")
    assert c.post(URL, json=as_json(poses(10))).status_code == 200


def test_unsupported_media_types(client):
    assert_error(client.post(URL, content=b"x", headers={"Content-Type": "text/csv"}), 415,
                 None, "unsupported_media_type")
    assert_error(client.post(URL, json=as_json(poses(2)), headers={"Accept": "text/html"}), 406,
                 None, "not_acceptable")


def test_json_floats_round_trip_exactly(client):
    """orjson writes the shortest repr of each float64: JSON and npz carry the same bits."""
    columns = poses(200, seed=9)
    text = orjson.loads(client.post(URL, json=as_json(columns)).content)
    binary = load_npz(client.post(URL, json=as_json(columns), headers={"Accept": NPZ}).content)
    assert np.array_equal(np.asarray(text["point"]), binary["point"])
    assert np.array_equal(np.asarray(text["normal"]), binary["normal"])


def test_a_streamed_json_answer_equals_the_npz_answer(client):
    """More than STREAM_ROWS pairs: the JSON answer is streamed in pieces, solved in chunks of
    CHUNK_ROWS, and carries the same values as the npz answer and the exact solver."""
    from impactnet.models.compiled import CHUNK_ROWS
    from impactnet.service.codecs.answers import STREAM_ROWS
    from impactnet.service.codecs.stream import WHOLE_ROWS

    n = CHUNK_ROWS + STREAM_ROWS + 17
    assert n > WHOLE_ROWS  # too large to be encoded whole
    columns = poses(n, seed=12)
    include = "?include=manifold&include=paper_angles"
    as_text = client.post(URL + include, content=npz_bytes(columns),
                          headers={"Content-Type": NPZ, "Accept": "application/json"})
    as_npz = client.post(URL + include, content=npz_bytes(columns),
                         headers={"Content-Type": NPZ, "Accept": NPZ})
    assert as_text.status_code == 200 and as_npz.status_code == 200
    assert "content-length" not in as_text.headers  # streamed (chunked)
    assert "content-length" not in as_npz.headers
    text, binary = orjson.loads(as_text.content), load_npz(as_npz.content)
    assert text["n"] == n
    assert_same_answer(text, binary)
    expected = box_box(*(columns[k] for k in ("a_size", "a_position", "a_quaternion",
                                              "b_size", "b_position", "b_quaternion")))
    np.testing.assert_allclose(binary["point"], expected.point, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(binary["colliding"], expected.colliding)


def _whole_answer(answers, pairs, include, mode: str, version: str) -> dict:
    """The batch answer as one nested dict, each column read whole (no slices): a row with a
    NaN or an infinity is null, missing names are null."""
    from impactnet.service.codecs.answers import columns

    whole = {"n": len(answers), "mode": mode, "model_version": version}
    for column in columns(answers, pairs, include):
        values = column.read(0, column.rows)
        if values.dtype.kind == "f":
            finite = np.isfinite(values).reshape(len(values), -1).all(axis=1)
            values = [row if ok else None for row, ok in zip(values.tolist(), finite.tolist())]
        elif values.dtype.kind in "OU":  # names, None where missing
            values = values.tolist()
        target = whole
        for key in column.path[:-1]:
            target = target.setdefault(key, {})
        target[column.path[-1]] = values
    return whole


def test_json_pieces_are_the_bytes_of_one_orjson_call():
    """The streamed encoding (slices of STREAM_ROWS rows, nested objects opened and closed
    between columns) writes the bytes of one orjson call on the whole answer."""
    from impactnet.models.dispatch import Dispatcher
    from impactnet.service.codecs.answers import STREAM_ROWS, batch_json
    from impactnet.service.codecs.columns import batch_pairs
    from impactnet.service.scene import load_scene_view

    n = 2 * STREAM_ROWS + 5
    scene = load_scene_view("quay_crane")
    pairs = batch_pairs(poses(n, seed=13), scene, "zyx", n)
    include = ("manifold", "paper_angles")
    answers = Dispatcher().answer(pairs, "exact", include, margin=0.5)
    assert 0 < len(answers.contacts["depth"]) < n  # contacts, and rows without any
    assert np.isinf(answers.body["distance"]).any()  # nulls beyond the margin
    pieces = list(batch_json(answers, pairs, include, "auto", "v1"))
    whole = _whole_answer(answers, pairs, include, "auto", "v1")
    assert b"".join(pieces) == orjson.dumps(whole, option=orjson.OPT_SERIALIZE_NUMPY)
