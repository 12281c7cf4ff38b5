"""The client against a real server of the detailed scene: compound pairs and the ragged
batch, npz and JSON alike."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.service.client import ImpactClient, contacts_of
from tests.service.conftest import ServerProcess

IDENTITY = [1.0, 0.0, 0.0, 0.0]
HEIGHT = 2.591


@pytest.fixture(scope="module")
def detail_api():
    proc = ServerProcess(args=["--no-access-log", "--scene", "quay_crane_detail"])
    try:
        proc.wait_ready()
        with ImpactClient(proc.url) as client:
            yield client
    finally:
        proc.cleanup()


def test_a_compound_pair_and_a_ragged_batch_through_the_client(detail_api):
    a = {"object": "container40", "position": [0, 0, 0], "quaternion": IDENTITY}
    b = {"object": "spreader", "position": [0, 0.0045, HEIGHT / 2 + 0.405],
         "quaternion": IDENTITY}
    one = detail_api.contact(a, b)
    assert one["predictor"] == "oracle" and len(one["contacts"]) == 4
    columns = {"a_object": "container40", "a_position": np.zeros(3), "a_quaternion": IDENTITY,
               "b_object": np.array(["spreader", "container40"]),
               "b_position": np.array([b["position"], [0.01, 0, HEIGHT - 1e-3]]),
               "b_quaternion": IDENTITY}
    binary, text = detail_api.batch(columns), detail_api.batch(columns, binary=False)
    for answer in (binary, text):
        assert answer["depth"].shape == (2,) and answer["contacts"]["offsets"].tolist() == [
            0, 4, 44]
        assert sorted(contacts_of(answer, 0)["part_b"]) == sorted(
            c["part_b"] for c in one["contacts"])
    np.testing.assert_array_equal(binary["contacts"]["depth"], text["contacts"]["depth"])
    np.testing.assert_array_equal(binary["point"], text["point"])
