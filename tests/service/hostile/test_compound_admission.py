"""Issue #31, items 3, 5 and 6: compound work is admitted before it is done.

The broadphase counts the candidate part pairs and the caps refuse before any contact is solved
(the narrowphase is watched); the memory budget holds the compound working set and answer; the
part-contact caps stop the work as soon as a slice passes them; rows that cannot touch cost no
per-pair setup; large compound answers are streamed and equal the whole encoding.
"""
from __future__ import annotations

import io

import numpy as np
import pytest

from impactnet.models.compound import candidates as candidates_module
from impactnet.models.compound import hull as hull_module
from impactnet.models.dispatch import plan as dispatch_plan
from impactnet.models.dispatch import solve as dispatch_solve
from tests.service.conftest import assert_error

LEVEL = [1.0, 0.0, 0.0, 0.0]
make_hull = hull_module._make
NPZ = {"Content-Type": "application/x-npz", "Accept": "application/x-npz"}
#: B over A: two 40 ft containers pushed 5 cm into each other side by side (237 candidate
#: part pairs at detail 2), and stacked castings on castings (40 part contacts).
OVERLAP, STACKED = [0.05, 0.0, 0.0], [0.0, 0.0, 2.589]


def _npz(**columns) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    return buffer.getvalue()


def _containers(rows: int, position) -> bytes:
    """A ~1.3 KB npz of ``rows`` container40-on-container40 poses (int8 angles)."""
    return _npz(a_object=np.array("container40"), b_object=np.array("container40"),
                a_position=np.zeros(3), b_position=np.array(position, float),
                a_euler=np.zeros(3), b_euler=np.zeros((rows, 3), np.int8))


@pytest.fixture
def solved(monkeypatch):
    """The narrowphase's calls (where the dispatcher looks it up): each slice of poses
    solved, as (start, stop)."""
    calls = []
    answer = candidates_module.answer_of_poses

    def watched(*args):
        calls.append(args[-2:])
        return answer(*args)

    monkeypatch.setattr(dispatch_solve, "answer_of_poses", watched)
    return calls


def test_a_batch_past_the_request_cap_is_413_before_any_contact_is_solved(make_client,
                                                                         solved):
    client = make_client(scene="quay_crane_detail", max_candidates_per_request=10_000)
    response = client.post("/v2/contact/batch", content=_containers(100, OVERLAP), headers=NPZ)
    answer = assert_error(response, 413, error="too_many_candidates")
    assert answer["limit"] == "max_candidates_per_request" and solved == []
    assert 'reason="max_candidates_per_request"} 1.0' in client.get("/metrics").text


def test_a_pose_past_the_pose_cap_is_413_naming_its_row(make_client, solved):
    client = make_client(scene="quay_crane_detail", max_candidates_per_pose=100)
    body = {"a_object": "container40", "b_object": "container40", "a_position": [0, 0, 0],
            "b_position": [STACKED, STACKED, OVERLAP], "a_quaternion": LEVEL,
            "b_quaternion": LEVEL}
    answer = assert_error(client.post("/v2/contact/batch", json=body), 413)
    assert answer["limit"] == "max_candidates_per_pose" and "row 2" in answer["message"]
    assert solved == []


def test_the_shipped_scenes_worst_poses_pass_the_default_caps(make_client):
    client = make_client(scene="quay_crane_detail")
    body = {"a_object": "container40", "b_object": ["container40", "container40", "spreader",
                                                     "container20"],
            "a_position": [0, 0, 0], "b_position": [OVERLAP, STACKED, [0, 0.0045, 1.7005],
                                                    [3.0, 0.0, 2.589]],
            "a_quaternion": LEVEL, "b_quaternion": LEVEL}
    response = client.post("/v2/contact/batch", json=body)
    assert response.status_code == 200, response.text


def test_the_part_contact_cap_stops_the_work_at_the_first_slice_past_it(make_client, solved):
    client = make_client(scene="quay_crane_detail", max_part_contacts_per_batch=100)
    response = client.post("/v2/contact/batch", content=_containers(500, STACKED), headers=NPZ)
    answer = assert_error(response, 413, error="too_many_part_contacts")
    assert answer["limit"] == "max_part_contacts_per_batch"
    assert len(solved) == 1  # 51 poses x 40 contacts in the first slice: stopped there


def test_a_compound_batch_reserves_its_memory_first(make_client, solved):
    client = make_client(scene="quay_crane_detail")
    response = client.post("/v2/contact/batch", content=_containers(200, STACKED), headers=NPZ)
    assert response.status_code == 200
    peak = client.app.state.runtime.budget.peak
    assert peak >= (200 * 40 * dispatch_plan.CONTACT_BYTES
                    + dispatch_plan.SLICE_WORKING_BYTES)
    assert client.app.state.runtime.budget.used == 0  # released with the answer


def test_no_room_in_the_budget_is_503_before_any_contact_is_solved(make_client, solved):
    client = make_client(scene="quay_crane_detail", memory_wait_s=0.0)
    budget = client.app.state.runtime.budget
    budget.reserve(budget.limit - (1 << 20), "another request")
    try:
        response = client.post("/v2/contact/batch", content=_containers(200, STACKED),
                               headers=NPZ)
    finally:
        budget.release(budget.limit - (1 << 20))
    assert_error(response, 503, error="overloaded")
    assert response.headers["retry-after"] and solved == []


def test_a_batch_that_could_never_fit_the_budget_is_413(make_client, solved):
    client = make_client(scene="quay_crane_detail", memory_budget_bytes=64 << 20)
    response = client.post("/v2/contact/batch", content=_containers(20_000, STACKED),
                           headers=NPZ)
    assert_error(response, 413, error="batch_too_large")
    assert solved == []


def test_distinct_pairs_that_cannot_touch_cost_no_per_pair_setup(make_client, monkeypatch):
    counted = []
    monkeypatch.setattr(dispatch_plan, "candidate_pairs",
                        lambda *a, **k: counted.append(1) or candidates_module.candidate_pairs(
                            *a, **k))
    client = make_client(scene="quay_crane_detail")

    def far_boxes(rows: int, seed: int) -> bytes:
        sizes = np.random.default_rng(seed).uniform(0.5, 2.0, (rows, 3))
        return _npz(a_size=sizes, b_object=np.array("container40"), a_position=np.zeros(3),
                    b_position=np.array([50.0, 0, 0]), a_euler=np.zeros(3),
                    b_euler=np.zeros(3))

    client.post("/v2/contact/batch", content=far_boxes(1, 1), headers=NPZ)  # the scene's hulls
    hulls = []  # a separated row's normal comes from its closest part pair: no hull per row
    monkeypatch.setattr(hull_module, "_make", lambda *a: hulls.append(1) or make_hull(*a))
    response = client.post("/v2/contact/batch", content=far_boxes(2_000, 0), headers=NPZ)
    assert response.status_code == 200
    answer = np.load(io.BytesIO(response.content))
    assert not answer["colliding"].any() and len(answer["colliding"]) == 2_000
    assert counted == []  # no group was formed: the rows were culled by their spheres
    assert hulls == []  # regression: each distinct box size once built a hull (0.6 ms)
    assert np.isfinite(answer["normal"]).all() and (answer["normal"] != 0).any(axis=1).all()


def _boxes_by_a_container(rows: int, seed: int, position, repeats: int = 1) -> bytes:
    """``rows`` distinct box sizes, each ``repeats`` times, at ``position`` from a container40
    (npz)."""
    sizes = np.tile(np.random.default_rng(seed).uniform(0.5, 2.0, (rows, 3)), (repeats, 1))
    return _npz(a_size=sizes, b_object=np.array("container40"), a_position=np.zeros(3),
                b_position=np.array(position, float), a_euler=np.zeros(3),
                b_euler=np.zeros(3))


def test_distinct_pairs_that_may_touch_past_the_cap_are_413_before_any_setup(
        make_client, monkeypatch, solved):
    counted = []
    monkeypatch.setattr(dispatch_plan, "candidate_pairs",
                        lambda *a, **k: counted.append(1) or candidates_module.candidate_pairs(
                            *a, **k))
    client = make_client(scene="quay_crane_detail", max_shape_pairs_per_request=20)
    near = [0.0, 0.0, 1.5]  # every box within reach of the container
    response = client.post("/v2/contact/batch", content=_boxes_by_a_container(21, 0, near),
                           headers=NPZ)
    answer = assert_error(response, 413, error="too_many_shape_pairs")
    assert answer["limit"] == "max_shape_pairs_per_request"
    assert "name 21 distinct pairs" in answer["detail"][0]["reason"]
    assert counted == [] and solved == []  # refused by the plan: no group was counted
    assert 'reason="max_shape_pairs_per_request"} 1.0' in client.get("/metrics").text
    served = client.post("/v2/contact/batch",  # rows of one size share their pair
                         content=_boxes_by_a_container(20, 0, near, repeats=50), headers=NPZ)
    assert served.status_code == 200 and len(counted) == 20
    assert len(np.load(io.BytesIO(served.content))["colliding"]) == 1_000
    far = client.post("/v2/contact/batch",  # rows that cannot touch are not groups
                      content=_boxes_by_a_container(2_000, 1, [50.0, 0, 0]), headers=NPZ)
    assert far.status_code == 200


@pytest.mark.parametrize("accept", ["application/json", "application/x-npz"])
def test_a_large_compound_answer_is_streamed_and_equals_the_whole(make_client, accept):
    client = make_client(scene="quay_crane_detail")
    rows = 600  # 24,000 part contacts: past WHOLE_ROWS
    response = client.post("/v2/contact/batch", content=_containers(rows, STACKED),
                           headers={"Content-Type": "application/x-npz", "Accept": accept})
    assert response.status_code == 200
    assert "content-length" not in response.headers  # chunked
    small = client.post("/v2/contact/batch", content=_containers(1, STACKED),
                        headers={"Content-Type": "application/x-npz", "Accept": accept})
    assert "content-length" in small.headers  # encoded whole
    if accept == "application/json":
        whole, one = response.json(), small.json()
        assert whole["n"] == rows and len(whole["contacts"]["offsets"]) == rows + 1
        assert whole["contacts"]["part_a"][:40] == one["contacts"]["part_a"]
        np.testing.assert_array_equal(whole["contacts"]["point"][:40], one["contacts"]["point"])
        assert whole["feature_a"]["part"][:1] == one["feature_a"]["part"]
        np.testing.assert_array_equal(whole["point"][:1], one["point"])
        return
    whole, one = np.load(io.BytesIO(response.content)), np.load(io.BytesIO(small.content))
    assert set(whole.files) == set(one.files)
    for name in set(one.files) - {"n", "contact_offsets"}:
        if one[name].ndim == 0:  # mode, model_version
            assert whole[name] == one[name], name
            continue
        part_contact = name.startswith("contact_") and name != "contact_type"  # not the pair's
        np.testing.assert_array_equal(whole[name][:40 if part_contact else 1], one[name],
                                      err_msg=name)
    assert whole["contact_offsets"][-1] == rows * 40 and whole["n"] == rows
