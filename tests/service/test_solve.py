"""The serving core's solve (service/solve.py): each step runs in the lane its known cost
chooses, and a step whose lane is the previous step's runs on in the same thread, without a
hop back to the event loop."""
from __future__ import annotations

import io
import threading

import numpy as np
import pytest

from impactnet.service import solve as service_solve
from impactnet.service.limits.lanes import Work

SPREADER = {"a": {"object": "container40", "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
            "b": {"object": "spreader", "position": [0, 0.0045, 1.7005],
                  "quaternion": [1, 0, 0, 0]}, "mode": "exact"}


@pytest.fixture
def steps(monkeypatch):
    """The threads each step ran in (``[(step, thread name)]``) and the costs of the solve's
    lane hops (a request's other work, such as decoding a batch, is not counted)."""
    seen, hops = [], []
    for name in ("_plan", "_count", "_solve"):
        step = getattr(service_solve, name)

        def traced(*args, _step=step, _name=name):
            seen.append((_name, threading.current_thread().name))
            return _step(*args)

        monkeypatch.setattr(service_solve, name, traced)
    run = Work.run

    async def counted(self, cost, function, *args):
        if function is service_solve._steps:
            hops.append(cost)
        return await run(self, cost, function, *args)

    monkeypatch.setattr(Work, "run", counted)
    return seen, hops


def _stacked_npz(rows: int) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, a_object=np.array("container40"), b_object=np.array("container40"),
             a_position=np.zeros(3), b_position=np.array([0.0, 0.0, 2.589]),
             a_euler=np.zeros(3), b_euler=np.zeros((rows, 3)))
    return buffer.getvalue()


def test_a_compound_pair_is_planned_counted_and_solved_in_one_hop(make_client, steps):
    client = make_client(scene="quay_crane_detail")
    response = client.post("/v2/contact", json=SPREADER)
    assert response.status_code == 200 and response.json()["colliding"] is True
    seen, hops = steps
    assert [name for name, _ in seen] == ["_plan", "_count", "_solve"]
    assert len(hops) == 1 and len({thread for _, thread in seen}) == 1
    assert seen[0][1].startswith("impactnet-small")


def test_a_step_that_costs_more_than_small_work_moves_to_the_large_lane(make_client, steps):
    # 40 stacked rows: planned in the small lane (40 rows), but their candidates cost more
    # than small_work_max box solves: the count and the solve hop to the large lane, together.
    client = make_client(scene="quay_crane_detail", small_work_max=64)
    response = client.post("/v2/contact/batch", content=_stacked_npz(40),
                           headers={"Content-Type": "application/x-npz"})
    assert response.status_code == 200
    seen, hops = steps
    threads = [thread for _, thread in seen]
    assert [name for name, _ in seen] == ["_plan", "_count", "_solve"]
    assert threads[0].startswith("impactnet-small") and threads[1].startswith("impactnet-batch")
    assert threads[2] == threads[1]
    assert len(hops) == 2 and hops[0] == 40 and hops[1] > 64


def test_the_answer_is_the_one_of_the_steps_run_apart(make_client):
    client = make_client(scene="quay_crane_detail")
    one_hop = client.post("/v2/contact", json=SPREADER).json()
    state = client.app.state.runtime.serving
    from impactnet.service.codecs.answers import row_json
    from impactnet.service.codecs.pair import part_limits, request_pairs
    from impactnet.service.codecs.requests import ContactRequest

    settings = client.app.state.runtime.settings
    pairs, _ = request_pairs(ContactRequest.model_validate(SPREADER), state.scene,
                             part_limits(settings))
    answers = service_solve.solve_now(state.dispatcher, pairs, "exact", (), 0.0, settings)
    apart = row_json(answers, pairs, ())
    assert {k: v for k, v in one_hop.items() if k in apart} == apart
