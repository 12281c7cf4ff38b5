"""The common battery over every predictor (exact, single, committee, auto), dispatch of
swapped and unsupported pairs, and load_predictor's errors."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from impactnet import models
from impactnet.models import contacts as ct
from impactnet.models import predictors as pr
from impactnet.models.box.exact import box_box
from impactnet.models.bundle.format import BundleError
from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.geometry.rotations import (
    quaternion_multiply,
    quaternion_to_matrix,
    random_quaternions,
)
from impactnet.models.learned.bundle_loader import read_bundle
from impactnet.models.learned.pair_dispatch import UnsupportedPairError
from impactnet.models.learned.region_label import unclipped_points
from tests.models.helpers import KEYS, assert_finite, labelled_rows
from tests.models.learned.learned_fixtures import (
    PAIRS,
    bundle_content,
    with_auto,
    write_test_bundle,
)
from tests.models.learned.test_mlp import random_mlp

NAMES = ("exact", "single", "committee", "auto")
#: Agreement of two learned answers of the same pose computed in different frames (a rigid
#: motion of the pair): the networks' float64 features differ by rounding, which their layers
#: may amplify; x the pair scale (metres).
LEARNED_TOL_REL = 2e-5
#: Share of rows allowed to change region between two such paths (argmax at a boundary).
REGION_FLIP_MAX = 0.01


@pytest.fixture(scope="module")
def content():
    return bundle_content()


@pytest.fixture(scope="module")
def bundle(content, tmp_path_factory):
    return read_bundle(write_test_bundle(tmp_path_factory.mktemp("b") / "bundle",
                                         content=content))


@pytest.fixture(scope="module", params=NAMES)
def predictor(request, bundle):
    return models.load_predictor(request.param, bundle)


def pair_rows(key, n=600, seed=5, offset=0.0):
    size_a, size_b = PAIRS[key]
    rows = labelled_rows(size_a, size_b, n, seed)
    rows["position_a"] = rows["position_a"] + offset
    rows["position_b"] = rows["position_b"] + offset
    return [rows[k] for k in KEYS]


def mixed_rows():
    """Rows of both pairs, the brick/slab rows half swapped, in one batch."""
    a = pair_rows("brick/slab", 400, seed=1)
    b = pair_rows("cube/cube", 300, seed=2)
    swapped = [a[3 + i] if i < 3 else a[i - 3] for i in range(6)]
    return [np.concatenate([x[:200], y, z[200:]]) for x, y, z in zip(a, b, swapped)]


def test_battery_shapes_dtypes_and_values(predictor):
    args = mixed_rows()
    n = len(args[0])
    c = predictor(*args)
    assert len(c) == n
    expected = {"colliding": (bool, (n,)), "normal": (np.float64, (n, 3)),
                "depth": (np.float64, (n,)), "point": (np.float64, (n, 3)),
                "contact_type_code": (np.int8, (n,)), "feature_a": (np.int8, (n,)),
                "feature_b": (np.int8, (n,)), "axis": (np.int8, (n,)),
                "manifold_points": (np.float64, (n, 8, 3)),
                "manifold_depths": (np.float64, (n, 8)), "manifold_count": (np.int8, (n,)),
                "confidence": (np.float64, (n,))}
    for name, (dtype, shape) in expected.items():
        value = getattr(c, name)
        assert value.dtype == dtype and value.shape == shape, name
    assert c.predictor.shape == (n,) and c.predictor.dtype.kind == "U"
    assert set(np.unique(c.predictor)) <= {predictor.mode, "committee", "exact"}
    assert_finite(c)
    np.testing.assert_allclose(np.linalg.norm(c.normal, axis=1), 1.0, atol=1e-6)
    assert (c.depth >= 0).all() and ((c.confidence >= 0) & (c.confidence <= 1)).all()
    assert set(c.contact_type) <= set(CONTACT_TYPES)
    count = c.manifold_count.astype(int)
    assert (np.abs(c.manifold_points[np.arange(8)[None] >= count[:, None]]) == 0).all()
    assert (c.feature_a[~c.colliding] == -1).all()


def test_battery_empty_batch(predictor):
    empty3, empty4 = np.zeros((0, 3)), np.zeros((0, 4))
    c = predictor(empty3, empty3, empty4, np.ones(3), empty3, empty4)
    assert len(c) == 0 and c.manifold_points.shape == (0, 8, 3)


def test_battery_batch_of_one_equals_a_row(predictor):
    """One pair alone is its row of the batch to the last bit: every predictor runs one row
    function for both (the learned ones: impactnet.models.learned.kernel_pair)."""
    args = mixed_rows()
    batch = predictor(*args)
    for i in range(0, len(args[0]), 23):
        one = predictor(*(a[i] for a in args))
        assert len(one) == 1
        for name, value in one.arrays().items():
            np.testing.assert_array_equal(value[0], getattr(batch, name)[i], err_msg=name)


def _moved(args, q, shift):
    """The same poses after the rigid motion x -> R(q) x + shift."""
    rot = quaternion_to_matrix(q)[0]
    size_a, pa, qa, size_b, pb, qb = args
    return [size_a, pa @ rot.T + shift, quaternion_multiply(q, qa), size_b, pb @ rot.T + shift,
            quaternion_multiply(q, qb)], rot


def test_battery_rigid_motion_invariance(predictor):
    args = mixed_rows()
    q = random_quaternions(1, np.random.default_rng(8))
    moved, rot = _moved(args, q, np.array([3e4, -1e4, 2e3]))
    c0, c1 = predictor(*args), predictor(*moved)
    same = (c0.contact_type_code == c1.contact_type_code) & (c0.predictor == c1.predictor)
    assert (~same).mean() <= REGION_FLIP_MAX
    tol = LEARNED_TOL_REL * 2.0 + 1e-10 * 3e4  # rounding of the far world coordinates
    np.testing.assert_allclose(c1.normal[same], (c0.normal @ rot.T)[same], atol=1e-5)
    np.testing.assert_allclose(c1.point[same], (c0.point @ rot.T + [3e4, -1e4, 2e3])[same],
                               atol=tol)
    np.testing.assert_allclose(c1.depth[same], c0.depth[same], atol=tol)
    for name in ("colliding", "feature_a", "feature_b", "axis"):
        np.testing.assert_array_equal(getattr(c1, name)[same], getattr(c0, name)[same])
    np.testing.assert_allclose(c1.confidence[same], c0.confidence[same], atol=1e-4)


def test_battery_swapped_pair_is_flipped(predictor):
    args = pair_rows("brick/slab", 300, seed=11)
    swapped = args[3:] + args[:3]
    c, s = predictor(*args), predictor(*swapped)
    learned = predictor.mode != "exact"
    same = (c.predictor == s.predictor) & (c.confidence > 0.0) if learned else np.ones(300, bool)
    mirror = {name: "-".join(reversed(name.split("-"))) for name in CONTACT_TYPES}
    if learned:  # exactly the same computation: equal to rounding
        np.testing.assert_allclose(s.normal[same], -c.normal[same], atol=1e-9)
        np.testing.assert_allclose(s.point[same], c.point[same], atol=1e-9)
        np.testing.assert_array_equal(s.feature_a[same], c.feature_b[same])
        np.testing.assert_array_equal(s.contact_type[same],
                                      [mirror[t] for t in c.contact_type[same]])
    hit = c.colliding & s.colliding  # the exact solver's tie rule may differ when swapped
    assert np.median(np.abs(s.normal + c.normal).sum(1)[hit]) < 1e-9
    np.testing.assert_array_equal(s.colliding, c.colliding)


def test_committee_labels_are_the_exact_solvers_and_its_point_beats_single(bundle):
    """The committee's colliding flag, type, features, axis and normal are the exact solver's, bit
    for bit (its region classifier is the exact labeller), and so is its depth except on overhanging
    face contacts (the labeller's SAT overlap, deeper; see impactnet.models.learned.region_label);
    its point comes from the experts and is better than the single network's."""
    args = pair_rows("brick/slab", 3000, seed=21)
    exact = box_box(*args)
    c = models.load_predictor("committee", bundle)(*args)
    for name in ("colliding", "contact_type_code", "feature_a", "feature_b", "axis", "normal"):
        np.testing.assert_array_equal(getattr(c, name), getattr(exact, name), err_msg=name)
    overhang = c.depth != exact.depth
    assert not (overhang & (exact.contact_type_code == 3)).any()
    assert (c.depth[overhang] > exact.depth[overhang]).all()
    single = models.load_predictor("single", bundle)(*args)
    hit = exact.colliding
    point_error = {name: np.linalg.norm(p.point - exact.point, axis=1)[hit]
                   for name, p in (("committee", c), ("single", single))}
    assert np.median(point_error["committee"]) < 0.5 * np.median(point_error["single"])


@pytest.mark.parametrize("name", ["single", "committee"])
def test_strict_modes_refuse_unsupported_rows(bundle, name):
    args = mixed_rows()
    args[0] = args[0].copy()
    args[0][[5, 17]] = [0.9, 0.6, 0.4]
    predictor = models.load_predictor(name, bundle)
    with pytest.raises(UnsupportedPairError, match=r"rows \[5, 17\]") as info:
        predictor(*args)
    assert info.value.rows == [5, 17] and isinstance(info.value, ValueError)
    with pytest.raises(UnsupportedPairError, match=r"rows \[0\]"):
        predictor(*(a[5] for a in args))


def test_auto_sends_unsupported_rows_to_exact(bundle):
    args = mixed_rows()
    args[0] = args[0].copy()
    args[0][[5, 17]] = [0.9, 0.6, 0.4]
    c = models.load_predictor("auto", bundle)(*args)
    exact = box_box(*(a[[5, 17]] for a in args))
    assert list(c.predictor[[5, 17]]) == ["exact", "exact"]
    np.testing.assert_array_equal(c.point[[5, 17]], exact.point)
    one = models.load_predictor("auto", bundle)(*(a[5] for a in args))
    assert one.predictor[0] == "exact"
    np.testing.assert_array_equal(one.normal[0], exact.normal[0])


def test_sizes_within_tolerance_use_the_pair_model(bundle):
    args = pair_rows("cube/cube", 50)
    nudged = list(args)
    nudged[0] = np.broadcast_to(np.array(PAIRS["cube/cube"][0]) * (1 + 3e-7), (50, 3))
    c = models.load_predictor("committee", bundle)
    np.testing.assert_allclose(c(*nudged).normal, c(*args).normal, atol=1e-5)


def test_load_predictor_errors(tmp_path, monkeypatch, content):
    assert isinstance(models.load_predictor("exact"), pr.ExactPredictor)
    with pytest.raises(ValueError, match="unknown predictor"):
        models.load_predictor("fast")
    monkeypatch.setattr(pr, "DEFAULT_BUNDLE", tmp_path / "missing")
    with pytest.raises(BundleError, match="needs a trained bundle"):
        models.load_predictor("committee")
    folder = write_test_bundle(tmp_path / "b", content=content)
    weights = folder / "weights.safetensors"
    data = bytearray(weights.read_bytes())
    data[len(data) // 2] ^= 0x01
    weights.write_bytes(bytes(data))
    with pytest.raises(BundleError, match="SHA-256"):
        models.load_predictor("auto", folder)


def test_invalid_input_raises_as_the_exact_solver(bundle):
    args = pair_rows("cube/cube", 5)
    args[1] = args[1].copy()
    args[1][2, 0] = np.nan
    for name in NAMES:
        with pytest.raises(ValueError, match="position_a"):
            models.load_predictor(name, bundle)(*args)


@pytest.mark.parametrize("auto, share", [
    ({"confidence_min": 1.0, "normal_spread_max_deg": 0.0, "point_spread_max": 0.0,
      "depth_margin": 0.0}, "all"),
    ({"confidence_min": 0.0, "normal_spread_max_deg": 180.0, "point_spread_max": 100.0,
      "depth_margin": 0.98}, "none"),
    ({"confidence_min": 0.08, "normal_spread_max_deg": 20.0, "point_spread_max": 0.5,
      "depth_margin": 0.005}, "some"),
])
def test_auto_sends_exactly_the_unsure_rows_to_exact(tmp_path, content, auto, share):
    manifest, tensors = content
    bundle = read_bundle(write_test_bundle(tmp_path / "b",
                                           content=(with_auto(manifest, **auto), tensors)))
    args = mixed_rows()
    committee = models.load_predictor("committee", bundle).predict(*args)
    c = committee.contacts
    edge = np.full(len(c), 0.3)  # brick/slab rows (0:200, 500:): shortest edge 0.3 m
    edge[200:500] = 1.0  # the cube rows
    exact_point = unclipped_points(*args)[1]
    untrusted = c.colliding & (c.contact_type_code == ct.FACE_FACE) & ~exact_point
    unsure = (untrusted  # auto never trusts the experts on a clipped face-face contact
              | (c.predictor == "exact")  # a region without a committee: exact in both modes
              | (c.confidence < auto["confidence_min"])
              | (committee.normal_spread > auto["normal_spread_max_deg"])
              | (committee.point_spread > auto["point_spread_max"] * edge))
    result = models.load_predictor("auto", bundle).predict(*args)
    a = result.contacts
    np.testing.assert_array_equal(a.predictor == "exact", unsure)
    # "all": every contact with a learned point; separated rows and rows whose unclipped point
    # is exact are the labeller's answers, kept as they are
    learned_unsure = unsure & (c.predictor != "exact") & ~untrusted
    learned_point = c.colliding & ~exact_point
    assert {"all": (unsure == learned_point).all(), "none": not learned_unsure.any(),
            "some": 0.05 < unsure[learned_point].mean() < 0.95}[share], unsure.mean()
    exact = box_box(*(x[unsure] for x in args))
    for name, value in exact.arrays().items():
        np.testing.assert_array_equal(getattr(a, name)[unsure], value, err_msg=name)
    for name, value in c.arrays().items():
        np.testing.assert_array_equal(getattr(a, name)[~unsure], value[~unsure], err_msg=name)
    assert (result.normal_spread[unsure] == 0).all()
    for i in np.flatnonzero(unsure)[:3].tolist() + np.flatnonzero(~unsure)[:3].tolist():
        one = models.load_predictor("auto", bundle)(*(x[i] for x in args))
        assert one.predictor[0] == a.predictor[i]


def test_committees_of_different_sizes_and_architectures(tmp_path, content):
    manifest, tensors = copy.deepcopy(content[0]), dict(content[1])
    entry = manifest["pairs"]["brick/slab"]
    regions = entry["classifier"]["regions"][1:]
    for region in regions[::2]:  # every other region: 2 members instead of 3
        dropped = entry["experts"][region].pop()
        del manifest["mlps"][dropped]
        for key in [k for k in tensors if k.startswith(dropped + ".")]:
            del tensors[key]
    wide = random_mlp((12, 20, 20, 7), seed=9,  # one member of another architecture
                      outputs="contact-residual-v1")
    name = entry["experts"][regions[1]][0]
    manifest["mlps"][name] = wide.spec.to_dict()
    tensors = {k: v for k, v in tensors.items() if not k.startswith(name + ".")}
    tensors.update(wide.to_tensors(name))
    bundle = read_bundle(write_test_bundle(tmp_path / "b", content=(manifest, tensors)))
    predictor = models.load_predictor("committee", bundle)
    args = pair_rows("brick/slab", 400, seed=13)
    batch = predictor.predict(*args)
    assert_finite(batch.contacts)
    for i in range(0, 400, 9):
        one = predictor.predict(*(a[i] for a in args))
        if one.contacts.contact_type_code[0] != batch.contacts.contact_type_code[i]:
            continue
        np.testing.assert_allclose(one.contacts.point[0], batch.contacts.point[i], atol=4e-5)
        np.testing.assert_allclose(one.normal_spread[0], batch.normal_spread[i], atol=1e-2)
        np.testing.assert_allclose(one.point_spread[0], batch.point_spread[i], atol=1e-4)


def test_swapped_request_at_an_exact_tie_is_named_as_the_exact_solver_names_it(bundle):
    """Regression: a request in the bundle's other order (slab, brick) lying flat and aligned
    ties A's and B's face axes; the exact solver names A's face (axis 2). The committee used to
    label the pair in the bundle's order and name B's face (axis 5)."""
    n = 50
    rng = np.random.default_rng(3)
    position_b = np.column_stack([rng.uniform(-0.4, 0.4, n), rng.uniform(-0.3, 0.3, n),
                                  np.full(n, 0.15 + 0.2 - 0.001)])
    args = [np.array(PAIRS["brick/slab"][1]), np.zeros(3), np.array([1.0, 0, 0, 0]),
            np.array(PAIRS["brick/slab"][0]), position_b, np.array([1.0, 0, 0, 0])]
    exact = box_box(*args)
    assert (exact.axis == 2).all()
    for name in ("committee", "auto"):
        predictor = models.load_predictor(name, bundle)
        batch = predictor(*args)
        one = predictor(*(a if a.ndim == 1 else a[0] for a in args))
        for label in ("axis", "contact_type_code", "feature_a", "feature_b", "normal"):
            np.testing.assert_array_equal(getattr(batch, label), getattr(exact, label))
            np.testing.assert_array_equal(getattr(one, label)[0], getattr(exact, label)[0])
