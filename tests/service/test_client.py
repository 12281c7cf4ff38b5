"""impactnet.service.client.ImpactClient against a real server process (keep-alive, JSON and
npz)."""
from __future__ import annotations

import socket

import numpy as np
import pytest

from impactnet.service.client import ImpactClient, ServiceError
from tests.service.conftest import PAIR
from tests.service.test_batch import poses


@pytest.fixture(scope="module")
def api(server):
    with ImpactClient(server.url) as client:
        yield client


def test_contact_and_models(api):
    assert api.ready()
    answer = api.contact(PAIR["a"], PAIR["b"], include=["manifold"])
    assert answer["colliding"] is True and answer["contacts"][0]["manifold"]["count"] >= 1
    assert api.last_model_version == answer["model_version"]
    assert api.models()["modes"]["available"] == ["exact"]
    arrays = api.contact({"object": "cube", "position": np.zeros(3),
                          "quaternion": np.array([1.0, 0, 0, 0])}, PAIR["b"])
    assert arrays["point"] == answer["point"]


def _flat(answer: dict, path: str = "") -> dict:
    """A nested batch answer's arrays by their path (``contacts.feature_a.id``)."""
    out = {}
    for key, value in answer.items():
        name = f"{path}{key}"
        out |= _flat(value, name + ".") if isinstance(value, dict) else {name: value}
    return out


def _assert_same_arrays(binary: dict, text: dict) -> None:
    """The same paths, each array of the same kind, shape and values in both encodings."""
    binary, text = _flat(binary), _flat(text)
    assert set(binary) == set(text), set(binary) ^ set(text)
    for name, value in binary.items():
        if isinstance(value, np.ndarray):
            assert value.dtype.kind == text[name].dtype.kind, name
            assert value.shape == text[name].shape, name
        np.testing.assert_array_equal(value, text[name], err_msg=name)


def test_batch_binary_equals_json(api):
    columns = poses(1000, seed=4)
    binary = api.batch(columns, include=["manifold", "paper_angles"], margin=0.5)
    text = api.batch(columns, include=["manifold", "paper_angles"], margin=0.5, binary=False)
    assert binary["model_version"] == text["model_version"] == api.last_model_version
    _assert_same_arrays(binary, text)
    assert binary["point"].shape == (1000, 3) and binary["point"].dtype == np.float64
    assert binary["feature_a"]["part"].dtype.kind == "U"
    assert np.isfinite(binary["closest_a"]).all(axis=1).any()  # gaps within the margin
    assert np.isinf(binary["distance"]).any()  # and beyond it
    assert binary["contacts"]["manifold_points"].shape[1:] == (8, 3)


def test_a_batch_without_any_contact_or_gap_is_the_same_in_both_encodings(api):
    """Columns that hold only nulls in JSON (no closest points, no angles, no part names) come
    back as the npz answer's arrays: NaN rows, empty names, no contacts."""
    far = {**poses(5, seed=6), "b_position": np.array([[50.0, 0.0, 0.0]] * 5)}
    binary = api.batch(far, include=["manifold", "paper_angles"])
    text = api.batch(far, include=["manifold", "paper_angles"], binary=False)
    _assert_same_arrays(binary, text)
    assert np.isnan(text["closest_b"]).all() and text["closest_b"].shape == (5, 3)
    assert np.isnan(text["paper_angles"]).all() and text["paper_angles"].shape == (5, 4)
    assert text["feature_a"]["part"].tolist() == [""] * 5
    assert text["contacts"]["point"].shape == (0, 3)


def test_errors_raise_service_error(api):
    with pytest.raises(ServiceError) as info:
        api.contact({**PAIR["a"], "quaternion": [0, 0, 0, 0]}, PAIR["b"])
    assert info.value.status == 422 and info.value.error == "invalid_input"
    assert info.value.body["detail"][0]["field"] == "a.quaternion"
    with pytest.raises(ServiceError) as info:
        api.contact(PAIR["a"], PAIR["b"], mode="committee")
    assert info.value.status == 409
    with pytest.raises(ServiceError) as info:
        api.batch({**poses(3), "a_position": np.zeros((2, 3))})
    assert info.value.status == 422 and info.value.body["detail"][0]["field"] == "a_position"
    assert api.contact(PAIR["a"], PAIR["b"])["colliding"]  # the connection still works


def test_reconnects_after_the_server_closes_the_connection(server, api):
    api.close()
    api.request("GET", "/healthz")
    api._conn.sock.shutdown(socket.SHUT_RDWR)  # as if the server had dropped the connection
    assert api.contact(PAIR["a"], PAIR["b"])["colliding"]
