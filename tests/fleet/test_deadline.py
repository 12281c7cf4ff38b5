"""Issue #31, item 7: the front never replays a request that a replica started to compute.

A request that runs past the replicas' compute deadline is stopped there and answered 504
``deadline_exceeded``; nginx neither retries the 504 nor times out first (its read timeout is
longer than the deadline), so the request ran on exactly one replica.
"""
from __future__ import annotations

import http.client
import io
import json
import re

import numpy as np
import pytest

from impactnet.service.fleet.local import Fleet

#: The replicas' deadline (s): short, so that the test is quick.
DEADLINE_S = 1.0


def _heavy() -> bytes:
    """~10 s of compound work in a 1.3 KB npz: 1,000 overlapping 40 ft container pairs."""
    buffer = io.BytesIO()
    np.savez(buffer, a_object=np.array("container40"), b_object=np.array("container40"),
             a_position=np.zeros(3), b_position=np.array([0.05, 0.0, 0.0]),
             a_euler=np.zeros(3), b_euler=np.zeros((1_000, 3), np.int8))
    return buffer.getvalue()


def _metric(port: int, pattern: str) -> float:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    conn.request("GET", "/metrics")
    text = conn.getresponse().read().decode()
    conn.close()
    return sum(float(v) for v in re.findall(pattern + r" ([0-9.e+]+)", text))


@pytest.mark.slow
def test_a_request_past_its_deadline_runs_on_exactly_one_replica(nginx):
    args = ["--scene", "quay_crane_detail", "--bundle", "none", "--no-access-log",
            "--compute-deadline", str(DEADLINE_S)]
    with Fleet(2, args, nginx=nginx) as fleet:
        conn = http.client.HTTPConnection("127.0.0.1", fleet.front.port, timeout=60)
        conn.request("POST", "/v2/contact/batch", _heavy(),
                     {"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
        response = conn.getresponse()
        body = response.read()
        assert response.status == 504, body[:300]
        assert json.loads(body)["error"] == "deadline_exceeded"
        batches = [_metric(m.port, r'impactnet_http_requests_total\{[^}]*route="/v2/contact/batch"'
                           r'[^}]*\}') for m in fleet.members]
        stopped = [_metric(m.port, "impactnet_deadline_exceeded_total") for m in fleet.members]
    assert sorted(batches) == [0.0, 1.0], batches  # one replica saw it, the other never
    assert sorted(stopped) == [0.0, 1.0], stopped
