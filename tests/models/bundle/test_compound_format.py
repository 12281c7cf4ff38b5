"""The compound pairs of a bundle (``compound_pairs``): a learned pair with a classifier and a
committee reads back as served models; an exact-only pair needs none; anything inconsistent is
refused with the entry named."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from impactnet.models.bundle.format import BundleError
from impactnet.models.learned.bundle_loader import read_bundle, write_bundle


def _mlp_tensors(name: str, widths: tuple[int, ...], seed: int) -> dict:
    rng = np.random.default_rng(seed)
    out = {}
    for k, (i, o) in enumerate(zip(widths[:-1], widths[1:])):
        out[f"{name}.w{k}"] = rng.normal(size=(o, i)).astype(np.float32)
        out[f"{name}.b{k}"] = np.zeros(o, np.float32)
    out[f"{name}.in_mean"] = np.zeros(widths[0], np.float32)
    out[f"{name}.in_scale"] = np.ones(widths[0], np.float32)
    out[f"{name}.out_mean"] = np.zeros(widths[-1], np.float32)
    out[f"{name}.out_scale"] = np.ones(widths[-1], np.float32)
    return out


#: Region codes: face-face, A's +z face on B's -z face; edge-edge, A's +x on B's -y.
TOP_ON_BOTTOM, EDGE_SIDE = 6 * 36 + 4 * 6 + 5, 3 * 36 + 0 * 6 + 3


def compound_content():
    """(manifest, tensors): one learned compound pair with 2 labels (3 region slots) and one
    committee."""
    tensors = _mlp_tensors("g.fl", (9, 8, 5), 0) | _mlp_tensors("r.m0", (9, 8, 8), 1)
    group = {"name": "fl", "parts_a": [0], "parts_b": [1], "centre_a": [0, 0, 0],
             "centre_b": [0, 0, 0], "labels": [[0, 1], [1, 1]],
             "regions": [[0, TOP_ON_BOTTOM], [1, EDGE_SIDE], [1, TOP_ON_BOTTOM]],
             "classifier": "g.fl",
             "temperature": 1.0, "candidate_min": 0.01, "domain_lo": [-1.0] * 9,
             "domain_hi": [1.0] * 9}
    region = {"expert": "committee", "members": ["r.m0"], "sure_min": 0.5,
              "normal_spread_max_deg": 1.0, "depth_spread_max_m": 1e-4,
              "contact_type_code": 6, "feature_a": 5, "feature_b": 0,
              "frame": {"centre_a": [0, 0, 0], "centre_b": [0, 0, 0]}, "figures": {}}
    manifest = {
        "version": "c-test", "scene": {"name": "t", "hash": "ab" * 32}, "pairs": {},
        "mlps": {"g.fl": {"activation": "tanh", "layers": [9, 8, 5],
                          "inputs": "group-pose-v1", "outputs": "part-labels-regions-v1"},
                 "r.m0": {"activation": "tanh", "layers": [9, 8, 8],
                          "inputs": "group-pose-v1", "outputs": "part-contact-v1"}},
        "compound_pairs": {"x/y": {
            "decision": {"serve": "learned", "figures": {"speedup_n1": 3.0}},
            "parts_a": ["p0", "p1"], "parts_b": ["q0", "q1"], "groups": [group],
            "regions": {f"0/1/{TOP_ON_BOTTOM}": region,
                        f"1/1/{EDGE_SIDE}": {"expert": "exact-part", "figures": {}}}}}}
    return manifest, tensors


def test_a_learned_compound_pair_reads_back_with_its_classifier_and_committee(tmp_path):
    manifest, tensors = compound_content()
    bundle = read_bundle(write_bundle(tmp_path / "b", manifest, tensors))
    models = bundle.compound["x/y"]
    assert models.serve == "learned" and bundle.pairs == {}
    (clf,) = models.classifiers
    assert clf.labels.tolist() == [[0, 1], [1, 1]] and clf.mlp.n_out == 5
    assert clf.region_label.tolist() == [0, 1, 1]
    assert clf.region_codes.tolist() == [TOP_ON_BOTTOM, EDGE_SIDE, TOP_ON_BOTTOM]
    assert set(models.committees) == {(0, 1, TOP_ON_BOTTOM)}
    assert models.regions[f"1/1/{EDGE_SIDE}"]["expert"] == "exact-part"


def test_an_exact_only_compound_pair_needs_no_models(tmp_path):
    manifest = {"version": "c", "scene": {"name": "t", "hash": "ab" * 32}, "pairs": {},
                "mlps": {}, "compound_pairs": {"x/y": {
                    "decision": {"serve": "exact-only", "figures": {}}}}}
    bundle = read_bundle(write_bundle(tmp_path / "b", manifest, {}))
    assert bundle.compound["x/y"].serve == "exact-only"
    assert bundle.compound["x/y"].classifiers == ()


def _broken(change):
    manifest, tensors = compound_content()
    manifest = copy.deepcopy(manifest)
    change(manifest["compound_pairs"]["x/y"], manifest)
    return manifest, tensors


@pytest.mark.parametrize("change, message", [
    (lambda e, m: e["decision"].update(serve="maybe"), "decision.serve"),
    (lambda e, m: e.update(groups=[]), "needs its groups"),
    (lambda e, m: e["groups"][0].update(classifier="nope"), "no MLP"),
    (lambda e, m: e["groups"][0]["labels"].append([5, 0]), "out of range"),
    (lambda e, m: e["groups"][0].update(candidate_min=1.0), "candidate_min"),
    (lambda e, m: e["groups"][0].update(domain_lo=[0.0] * 8), "domain_lo"),
    (lambda e, m: e["groups"][0].update(mirror=[1.0, 0.5, 1.0]), "mirror"),
    (lambda e, m: m["mlps"]["g.fl"].update(inputs="pose-v1"), "group-pose-v1"),
    (lambda e, m: e["groups"][0]["regions"].pop(0), "every label needs region slots"),
    (lambda e, m: e["groups"][0]["regions"].reverse(), "in label order"),
    (lambda e, m: e["groups"][0]["regions"][0].__setitem__(1, 3), "not a contact region"),
    (lambda e, m: e["groups"][0]["regions"].append([1, 250]), "must map"),  # 6 outputs needed
    (lambda e, m: e["regions"][f"0/1/{TOP_ON_BOTTOM}"].update(expert="oracle"), "expert"),
    (lambda e, m: e["regions"][f"0/1/{TOP_ON_BOTTOM}"].pop("sure_min"), "sure_min"),
    (lambda e, m: e["regions"].update({f"0/9/{TOP_ON_BOTTOM}": e["regions"][
        f"0/1/{TOP_ON_BOTTOM}"]}), "out of range"),
    (lambda e, m: e["regions"].update({"0/1/4000": e["regions"][f"0/1/{TOP_ON_BOTTOM}"]}),
     "out of range"),
    (lambda e, m: e["regions"].update({"0/1": e["regions"][f"0/1/{TOP_ON_BOTTOM}"]}),
     "regions\\['0/1'\\]"),  # a part pair without its coarse region: the old format
])
def test_an_inconsistent_compound_entry_is_refused_naming_it(tmp_path, change, message):
    manifest, tensors = _broken(change)
    with pytest.raises(BundleError, match=message):
        write_bundle(tmp_path / "b", manifest, tensors)
    assert not (tmp_path / "b").exists()


def test_a_bundle_with_neither_box_nor_compound_pairs_is_refused(tmp_path):
    manifest = {"version": "c", "scene": {"name": "t", "hash": "ab" * 32}, "pairs": {},
                "mlps": {}, "compound_pairs": {}}
    with pytest.raises(BundleError, match="non-empty"):
        write_bundle(tmp_path / "b", manifest, {})
