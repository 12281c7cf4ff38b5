"""A pair that the bundle serves exact-only (its `decision`, issue #21): every learned mode
answers it as the exact solver does, one pair and batch, and names the exact solver; the other
pair keeps its learned answers; a malformed decision is refused."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from impactnet import models
from impactnet.models.box.exact import box_box
from impactnet.models.bundle.format import BundleError
from impactnet.models.learned.bundle_loader import bundle_in_memory, read_bundle
from tests.models.helpers import KEYS, labelled_rows
from tests.models.learned.learned_fixtures import PAIRS, bundle_content, write_test_bundle

DECISION = {"serve": "exact-only", "figures": {"speedup_n1": 0.9, "speedup_batch": 0.7}}


@pytest.fixture(scope="module")
def content():
    return bundle_content()


@pytest.fixture(scope="module")
def decided(content, tmp_path_factory):
    """The test bundle with brick/slab exact-only (written and read back: the manifest
    round-trips through the checks)."""
    manifest, tensors = copy.deepcopy(content[0]), content[1]
    manifest["pairs"]["brick/slab"]["decision"] = DECISION
    folder = tmp_path_factory.mktemp("decided") / "bundle"
    return read_bundle(write_test_bundle(folder, content=(manifest, tensors)))


def _rows(key, n=300, seed=3, swap=False):
    size_a, size_b = PAIRS[key]
    rows = labelled_rows(size_a, size_b, n, seed)
    args = [rows[k] for k in KEYS]
    return (args[3:] + args[:3]) if swap else args


@pytest.mark.parametrize("mode", ["single", "committee", "auto"])
@pytest.mark.parametrize("swap", [False, True])
def test_every_mode_answers_an_exact_only_pair_as_the_exact_solver(decided, mode, swap):
    predictor = models.load_predictor(mode, decided)
    args = _rows("brick/slab", swap=swap)
    got, want = predictor(*args), box_box(*args)
    assert (got.predictor == "exact").all()
    for name, column in want.arrays().items():
        np.testing.assert_array_equal(getattr(got, name), column, err_msg=name)
    for k in range(5):  # one pair: the plain-float path
        one = predictor(*(a[k] for a in args))
        assert one.predictor[0] == "exact"
        np.testing.assert_allclose(one.point[0], want.point[k], atol=1e-12)
        np.testing.assert_allclose(one.depth[0], want.depth[k], atol=1e-12)


def test_the_other_pair_keeps_its_learned_answers(decided):
    args = _rows("cube/cube")
    assert (models.load_predictor("committee", decided)(*args).predictor == "committee").any()
    assert decided.pairs["brick/slab"].serve == "exact-only"
    assert decided.pairs["cube/cube"].serve == "learned"
    assert decided.pairs["brick/slab"].decision["figures"]["speedup_n1"] == 0.9


def test_an_exact_only_pair_needs_no_models(content):
    manifest = copy.deepcopy(content[0])
    entry = manifest["pairs"]["brick/slab"]
    for name in ("single", "classifier", "experts", "auto"):
        entry.pop(name, None)
    entry["decision"] = DECISION
    used = {m for e in manifest["pairs"].values() for m in
            [e.get("single"), *[n for names in e.get("experts", {}).values() for n in names]]}
    manifest["mlps"] = {k: v for k, v in manifest["mlps"].items() if k in used}
    tensors = {k: v for k, v in content[1].items() if k.rsplit(".", 1)[0] in used}
    bundle = bundle_in_memory(manifest, tensors)
    args = _rows("brick/slab")
    for mode in ("single", "committee", "auto"):
        got = models.load_predictor(mode, bundle)(*args)
        assert (got.predictor == "exact").all()
        np.testing.assert_array_equal(got.point, box_box(*args).point)


@pytest.mark.parametrize("decision,message", [
    ({"serve": "sometimes", "figures": {}}, "decision.serve"),
    ({"serve": "exact-only"}, "decision: expected an object"),
    ("exact-only", "decision: expected an object")])
def test_a_malformed_decision_is_refused(content, decision, message):
    manifest = copy.deepcopy(content[0])
    manifest["pairs"]["brick/slab"]["decision"] = decision
    with pytest.raises(BundleError, match=message):
        bundle_in_memory(manifest, content[1])
