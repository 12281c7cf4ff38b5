"""The learned path of compound pairs over HTTP (issue #21): with a bundle whose cell guide
pair is served learned, mode ``auto`` answers it through the chain (``exact-part`` or
``oracle`` per row, the oracle's answer wherever the classifier named the touching parts),
``committee`` without the oracle, ``exact`` and ``single`` with the oracle; the same pair in
the other order, or recorded exact-only, is answered by the oracle in every mode;
GET /v1/models lists the compound pairs with their decision."""
import io

import numpy as np
import pytest

from impactnet.models.compound import compound_answer
from impactnet.models.learned.bundle_loader import write_bundle
from impactnet.models.scenes import load_scene
from impactnet.training.compound.rows import split_rows
from tests.compound_bundle import GUIDE_PAIR, guide_manifest, guide_rows

IDENTITY = [1.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def bundles(tmp_path_factory):
    root = tmp_path_factory.mktemp("compound")
    learned = write_bundle(root / "learned", *guide_manifest(learned=True))
    exact_only = write_bundle(root / "exact_only", *guide_manifest(learned=False))
    return learned, exact_only


@pytest.fixture
def served(make_client, bundles):
    return make_client(scene="quay_crane_detail", bundle=str(bundles[0]))


def _held_out(k: int = 12):
    rows = split_rows(guide_rows(), 0)
    return rows.position[rows.test[:k]], rows.quaternion[rows.test[:k]]


def _batch(position, quaternion, mode, a="cell_guide", b="container40"):
    return {"a_object": a, "a_position": [0, 0, 0], "a_quaternion": IDENTITY, "b_object": b,
            "b_position": position.tolist(), "b_quaternion": quaternion.tolist(), "mode": mode}


def test_models_lists_the_compound_pairs_with_their_decision(served):
    pairs = served.get("/v1/models").json()["bundle"]["compound_pairs"]
    assert pairs[GUIDE_PAIR]["serve"] == "learned"
    assert pairs[GUIDE_PAIR]["modes"] == ["auto", "committee"]
    assert "speedup_n1" in pairs[GUIDE_PAIR]["decision"]


def test_auto_answers_through_the_chain_and_agrees_with_the_oracle_where_it_names_the_parts(
        served):
    position, quaternion = _held_out()
    answer = served.post("/v2/contact/batch", json=_batch(position, quaternion, "auto")).json()
    assert set(answer["predictor"]) <= {"exact-part", "oracle", "learned"}
    assert "exact-part" in answer["predictor"]
    scene = load_scene("quay_crane_detail")
    want = compound_answer(scene.body("cell_guide").parts, [0, 0, 0], IDENTITY,
                           scene.body("container40").parts, position, quaternion)
    same = np.diff(answer["contacts"]["offsets"]) == np.diff(want.parts.offsets)
    assert same.mean() > 0.8
    np.testing.assert_allclose(np.array(answer["depth"])[same], want.summary.depth[same],
                               atol=1e-12)


@pytest.mark.parametrize("mode, allowed", [("exact", {"oracle"}), ("single", {"oracle"}),
                                           ("committee", {"exact-part", "learned"})])
def test_each_mode_names_who_answered(served, mode, allowed):
    position, quaternion = _held_out(6)
    answer = served.post("/v2/contact/batch", json=_batch(position, quaternion, mode)).json()
    assert set(answer["predictor"]) <= allowed and answer["mode"] == mode


def test_one_pair_names_its_predictor_and_the_npz_carries_it(served):
    position, quaternion = _held_out(3)
    one = served.post("/v2/contact", json={
        "a": {"object": "cell_guide", "position": [0, 0, 0], "quaternion": IDENTITY},
        "b": {"object": "container40", "position": position[0].tolist(),
              "quaternion": quaternion[0].tolist()}, "mode": "auto"}).json()
    assert one["predictor"] in ("exact-part", "oracle", "learned")
    binary = served.post("/v2/contact/batch", json=_batch(position, quaternion, "auto"),
                         headers={"accept": "application/x-npz"})
    with np.load(io.BytesIO(binary.content), allow_pickle=False) as npz:
        assert set(npz["predictor"].tolist()) <= {"exact-part", "oracle", "learned"}


def test_the_pair_in_the_other_order_or_recorded_exact_only_is_answered_by_the_oracle(
        served, make_client, bundles):
    position, quaternion = _held_out(4)
    flipped = served.post("/v2/contact/batch", json=_batch(
        -position, quaternion, "auto", a="container40", b="cell_guide")).json()
    assert set(flipped["predictor"]) == {"oracle"}
    exact_only = make_client(scene="quay_crane_detail", bundle=str(bundles[1]))
    answer = exact_only.post("/v2/contact/batch",
                             json=_batch(position, quaternion, "auto")).json()
    assert set(answer["predictor"]) == {"oracle"}


def test_the_shipped_detail_bundle_loads_and_serves_its_recorded_decisions(make_client):
    served = make_client(scene="quay_crane_detail", bundle=None)  # the shipped bundle
    bundle = served.get("/v1/models").json()["bundle"]
    assert bundle["version"].startswith("quay_crane_detail-")
    pairs = bundle["compound_pairs"]
    assert set(pairs) == {"container40/container40", "container40/container20",
                          "container40/spreader", "cell_guide/container40"}
    position, quaternion = _held_out(3)
    answer = served.post("/v2/contact/batch", json=_batch(position, quaternion, "auto")).json()
    expected = {"oracle"} if pairs[GUIDE_PAIR]["serve"] == "exact-only" else {
        "oracle", "exact-part", "learned"}
    assert set(answer["predictor"]) <= expected


def test_a_bundle_of_compound_pairs_serves_every_mode_and_refuses_box_pairs_in_strict_ones(
        served):
    modes = served.get("/v1/models").json()["modes"]
    assert set(modes["available"]) == {"exact", "single", "committee", "auto"}
    box = {"a": {"size": [2.0, 2.0, 2.0], "position": [0, 0, 0], "quaternion": IDENTITY},
           "b": {"size": [2.0, 2.0, 2.0], "position": [0, 0, 1.99], "quaternion": IDENTITY}}
    assert served.post("/v2/contact", json=box | {"mode": "committee"}).status_code == 422
    assert served.post("/v2/contact", json=box | {"mode": "auto"}).json()["predictor"] == "exact"
