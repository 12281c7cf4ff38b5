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
    assert answer["colliding"] is True and answer["manifold"]["count"] >= 1
    assert api.last_model_version == answer["model_version"]
    assert api.models()["modes"]["available"] == ["exact"]
    arrays = api.contact({"object": "cube", "position": np.zeros(3),
                          "quaternion": np.array([1.0, 0, 0, 0])}, PAIR["b"])
    assert arrays["point"] == answer["point"]


def test_batch_binary_equals_json(api):
    columns = poses(1000, seed=4)
    binary = api.batch(columns, include=["manifold", "paper_angles"])
    text = api.batch(columns, include=["manifold", "paper_angles"], binary=False)
    assert binary["model_version"] == text["model_version"] == api.last_model_version
    for key in ("point", "normal", "depth", "colliding", "contact_type", "contact_type_code",
                "feature_a", "feature_b", "axis", "confidence", "predictor", "manifold_count",
                "manifold_points", "manifold_depths", "paper_angles"):
        np.testing.assert_array_equal(binary[key], text[key], err_msg=key)
    assert binary["point"].shape == (1000, 3) and binary["point"].dtype == np.float64


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
