"""POST /v2/frame and POST /v2/worlds (issue #34): a frame answers what the pairwise API answers
for each of its pairs, a registered world stands in for its bodies, and bad input names the
body by its id."""
from __future__ import annotations

import copy
import io

import numpy as np
import pytest
from fastapi.testclient import TestClient

from impactnet.service.app import create_app
from tests.service.conftest import assert_error, test_settings

#: A 40 ft container's height (m) and the overlap a stacked one is given (m).
HEIGHT, STACKED = 2.591, 0.002
STACK = [{"id": f"c{k}", "object": "container40",
          "position": [0.01 * k, 0.0, 0.5 * HEIGHT + k * (HEIGHT - STACKED)],
          "euler": [0.0, 0.0, 0.001 * k]} for k in range(3)]
SPREADER = {"id": "s1", "object": "spreader", "position": [0.0, 0.0, 8.6],
            "quaternion": [1.0, 0.0, 0.0, 0.0]}
GUIDE = {"id": "g1", "object": "cell_guide", "position": [-6.25, -1.4, 3.0],
         "quaternion": [1.0, 0.0, 0.0, 0.0]}


@pytest.fixture(scope="module")
def detail():
    settings = test_settings(scene="quay_crane_detail", max_frame_bodies=64, max_worlds=2)
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def _frame(client, bodies, **options):
    response = client.post("/v2/frame", json={"bodies": bodies} | options)
    assert response.status_code == 200, response.text
    return response.json()


def _pair(client, a, b, margin):
    strip = ("id",)
    body = {"a": {k: v for k, v in a.items() if k not in strip},
            "b": {k: v for k, v in b.items() if k not in strip}, "margin": margin}
    response = client.post("/v2/contact", json=body)
    assert response.status_code == 200, response.text
    return {k: v for k, v in response.json().items() if k not in ("mode", "model_version")}


@pytest.mark.parametrize("margin", [0.0, 0.5])
def test_each_pair_of_a_frame_answers_what_the_pairwise_api_answers(detail, margin):
    bodies = [*STACK, SPREADER, GUIDE]
    answer = _frame(detail, bodies, margin=margin)
    by_id = {b["id"]: b for b in bodies}
    assert answer["n_bodies"] == len(bodies) and answer["world"] is None
    assert {(p["a"], p["b"]) for p in answer["pairs"]} >= {("c0", "c1"), ("c1", "c2")}
    for pair in answer["pairs"]:
        expected = _pair(detail, by_id[pair["a"]], by_id[pair["b"]], margin)
        assert {k: v for k, v in pair.items() if k not in ("a", "b")} == expected
        assert pair["colliding"] or 0.0 <= pair["distance"] <= margin


@pytest.mark.parametrize("margin, asked", [(0.0, False), (0.5, True)])
def test_a_frame_at_margin_0_asks_no_gap_of_the_pairs_it_drops(detail, margin, asked,
                                                                monkeypatch):
    from impactnet.models.dispatch import solve as dispatch_solve

    calls = []
    gaps = dispatch_solve.bodies_gaps
    monkeypatch.setattr(dispatch_solve, "bodies_gaps",
                        lambda *args: calls.append(len(args[1])) or gaps(*args))
    answer = _frame(detail, [*STACK, SPREADER], margin=margin)  # the spreader apart
    assert bool(calls) is asked
    assert (("c2", "s1") in {(p["a"], p["b"]) for p in answer["pairs"]}) is asked


def test_a_small_frame_takes_one_hop_to_its_pairs_one_to_its_answers_one_to_its_text(
        detail, monkeypatch):
    from impactnet.service.limits.lanes import Work

    hops = []
    run = Work.run

    async def counted(self, cost, function, *args):
        hops.append(function.__name__)
        return await run(self, cost, function, *args)

    monkeypatch.setattr(Work, "run", counted)
    _frame(detail, [*STACK, SPREADER])  # parse, decode, broadphase: one thread, one hop
    assert hops == ["advance", "_steps", "frame_json"]


def test_a_registered_world_stands_in_for_its_bodies(detail):
    registered = detail.post("/v2/worlds", json={"bodies": STACK})
    assert registered.status_code == 200, registered.text
    world = registered.json()
    assert world["bodies"] == 3 and world["world"].startswith("w-")
    again = detail.post("/v2/worlds", json={"bodies": STACK}).json()
    assert again == world | {"created": False}
    moved = _frame(detail, [SPREADER], world=world["world"], margin=0.5)
    whole = _frame(detail, [*STACK, SPREADER], margin=0.5)
    assert moved["world"] == world["world"] and moved["n_bodies"] == 4
    # the world's own pairs (the stack) are static: never answered again
    assert moved["pairs"] == [p for p in whole["pairs"] if "s1" in (p["a"], p["b"])]


def test_a_world_sent_as_npz_gets_the_same_name_as_json(detail):
    columns = {"id": np.array([b["id"] for b in STACK]),
               "object": np.array(["container40"] * 3),
               "position": np.array([b["position"] for b in STACK]),
               "euler": np.array([b["euler"] for b in STACK])}
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    npz = detail.post("/v2/worlds", content=buffer.getvalue(),
                      headers={"content-type": "application/x-npz"})
    assert npz.status_code == 200, npz.text
    assert npz.json()["world"] == detail.post("/v2/worlds", json={"bodies": STACK}).json()[
        "world"]


def test_an_unknown_world_is_409_and_a_forgotten_one_too(detail):
    assert_error(detail.post("/v2/frame", json={"bodies": [SPREADER], "world": "w-00"}), 409,
                 error="unknown_world")
    names = [detail.post("/v2/worlds", json={"bodies": [dict(b, id=f"{b['id']}-{k}")
                                                        for b in STACK]}).json()["world"]
             for k in range(3)]  # max_worlds = 2: the first is forgotten
    body = assert_error(detail.post("/v2/frame", json={"bodies": [SPREADER],
                                                       "world": names[0]}), 409,
                        error="unknown_world")
    assert body["world"] == names[0]
    assert detail.post("/v2/frame", json={"bodies": [SPREADER],
                                          "world": names[2]}).status_code == 200


def test_npz_and_json_frames_carry_the_same_pairs_and_members(detail):
    bodies = [*STACK, SPREADER]
    answer = _frame(detail, bodies, margin=0.5)
    columns = {"id": np.array([b["id"] for b in bodies]),
               "object": np.array([b["object"] for b in bodies]),
               "position": np.array([b["position"] for b in bodies]),
               "quaternion": np.array([[1.0, 0, 0, 0]] * 4)}
    columns["quaternion"][:3] = [[np.cos(0.0005 * k), 0, 0, np.sin(0.0005 * k)]
                                 for k in range(3)]
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    response = detail.post("/v2/frame?margin=0.5", content=buffer.getvalue(),
                           headers={"content-type": "application/x-npz",
                                    "accept": "application/x-npz"})
    assert response.status_code == 200, response.text
    # A small answer is encoded whole, in one worker thread, and sent with its length.
    assert int(response.headers["content-length"]) == len(response.content)
    with np.load(io.BytesIO(response.content), allow_pickle=False) as npz:
        members = {k: npz[k] for k in npz.files}
    assert [(p["a"], p["b"]) for p in answer["pairs"]] == list(zip(
        members["a"].tolist(), members["b"].tolist(), strict=True))
    np.testing.assert_allclose(members["depth"], [p["depth"] for p in answer["pairs"]],
                               atol=1e-12)
    assert int(members["n_bodies"]) == 4
    flat = {"closest_a", "closest_b", "feature_a_part", "contact_offsets",
            "contact_feature_b_kind", "contact_pressure", "distance"}
    assert flat <= set(members)


@pytest.mark.parametrize(("change", "field", "error"), [
    (lambda b: b[2].update(id="c0"), "bodies[2] (id 'c0').id", "invalid_input"),
    (lambda b: b[1].update(object="crane"), "bodies[1] (id 'c1').object", "invalid_input"),
    (lambda b: b[3].update(position=[0, 0, "up"]), "bodies[3] (id 's1').position",
     "invalid_input"),
    (lambda b: b[3].pop("id"), "bodies[3].id", "invalid_input"),
    (lambda b: b[0].update(quaternion=[0, 0, 0, 0], euler=None) or b[0].pop("euler"),
     "bodies[0] (id 'c0').quaternion", "invalid_input"),
])
def test_bad_input_names_the_body_by_its_id(detail, change, field, error):
    bodies = copy.deepcopy([*STACK, SPREADER])
    change(bodies)
    body = assert_error(detail.post("/v2/frame", json={"bodies": bodies}), 422, error=error)
    assert any(d["field"].startswith(field) for d in body["detail"]), body


def test_a_nan_pose_in_an_npz_frame_names_its_row(detail):
    buffer = io.BytesIO()
    np.savez(buffer, id=np.array(["a", "b"]), size=np.ones((2, 3)),
             position=np.array([[0, 0, 0], [np.nan, 0, 0]]), quaternion=np.array([1.0, 0, 0, 0]))
    body = assert_error(detail.post("/v2/frame", content=buffer.getvalue(),
                                    headers={"content-type": "application/x-npz"}), 422,
                        field="position")
    assert body["detail"][0]["rows"] == [1]


def test_a_body_id_clashing_with_the_world_is_422(detail):
    world = detail.post("/v2/worlds", json={"bodies": STACK}).json()["world"]
    body = assert_error(detail.post("/v2/frame", json={"bodies": [dict(SPREADER, id="c1")],
                                                       "world": world}), 422)
    assert "c1" in body["message"] and world in body["message"]


def test_a_frame_past_its_limits_is_413_before_its_work(detail, make_client):
    many = [dict(SPREADER, id=f"s{k}") for k in range(65)]  # max_frame_bodies = 64
    assert_error(detail.post("/v2/frame", json={"bodies": many}), 413, error="too_many_bodies")
    small = make_client(scene="quay_crane_detail", max_batch_pairs=3)
    heap = [dict(SPREADER, id=f"s{k}") for k in range(4)]  # 6 pairs at one place
    body = assert_error(small.post("/v2/frame", json={"bodies": heap}), 413,
                        error="too_many_body_pairs")
    assert body["limit"] == "max_batch_pairs"


def test_the_scene_pairs_and_the_filter_drop_pairs(detail):
    side_by_side = [dict(SPREADER, id="s1"), dict(SPREADER, id="s2",
                                                  position=[0.0, 0.0, 8.61])]
    assert len(_frame(detail, side_by_side)["pairs"]) == 1
    assert _frame(detail, side_by_side, pairs="scene")["pairs"] == []  # spreader/spreader
    masked = [dict(side_by_side[0], contype=2, conaffinity=2), side_by_side[1]]
    assert _frame(detail, masked)["pairs"] == []
