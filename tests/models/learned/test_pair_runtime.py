"""The committee's spread (kernel_pair.spread), a pair's region table, and pair dispatch."""
from __future__ import annotations

import numpy as np
import pytest

from impactnet.models import contacts as ct
from impactnet.models.box.exact import box_box
from impactnet.models.learned.bundle_loader import Bundle
from impactnet.models.learned.bundle_pairs import PairModels
from impactnet.models.learned.canonical import REGION_LABELLER
from impactnet.models.learned.kernel_pair import spread
from impactnet.models.learned.pair_dispatch import (
    MIRROR_AXIS,
    MIRROR_TYPE,
    UNSUPPORTED,
    PairTable,
    groups,
    unswap,
)
from impactnet.models.learned.pair_runtime import PairRuntime
from tests.models.helpers import KEYS, labelled_rows
from tests.models.learned.test_mlp import random_mlp


def test_the_region_table_finds_committee_regions_and_flags_the_rest():
    models = PairModels("a/b", (1.0, 2.0, 3.0), (2.0, 2.0, 2.0), (0.0, 0.01), None,
                        REGION_LABELLER, ("none", "face-vertex:0:18", "edge-edge:6:10"),
                        {"face-vertex:0:18": ("e",), "edge-edge:6:10": ("e", "e")})
    pair = PairRuntime(models, Bundle({}, {"e": random_mlp((12, 8, 7))}, {}))
    code = np.array([ct.NONE, ct.FACE_VERTEX, ct.EDGE_EDGE, ct.FACE_VERTEX, ct.EDGE_EDGE])
    feature_a = np.array([-1, 0, 6, 1, 10])
    feature_b = np.array([-1, 18, 10, 18, 6])
    np.testing.assert_array_equal(pair.region_table[code, feature_a + 1, feature_b + 1],
                                  [0, 1, 2, -1, -1])
    assert pair.supports("committee") and not pair.supports("auto")


@pytest.mark.parametrize("k", [1, 2, 3, 5])
def test_the_spread_is_the_largest_pairwise_angle_and_distance(k):
    rng = np.random.default_rng(k)
    for _ in range(50):
        members = rng.normal(size=(k, 7))
        members[:, 3:6] *= rng.uniform(0.5, 2.0, (k, 1))
        normal_spread, point_spread = spread(members, k, 2.0)
        units = members[:, 3:6] / np.linalg.norm(members[:, 3:6], axis=1, keepdims=True)
        chord = np.linalg.norm(units[:, None] - units[None, :], axis=2).max()
        angle = np.degrees(2.0 * np.arcsin(min(chord / 2.0, 1.0)))  # well conditioned at 0
        dist = 2.0 * np.linalg.norm(members[:, None, :3] - members[None, :, :3], axis=2).max()
        np.testing.assert_allclose(normal_spread, angle, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(point_spread, dist, rtol=1e-12)
    assert spread(np.zeros((3, 7)), 3, 1.0) == (0.0, 0.0)  # short normals: the floor, no 0/0


def test_mirror_tables_are_involutions_and_match_the_exact_solver():
    assert (MIRROR_TYPE[MIRROR_TYPE] == np.arange(7)).all()
    assert (MIRROR_AXIS[MIRROR_AXIS[:15]] == np.arange(15)).all() and MIRROR_AXIS[-1] == -1
    size_a, size_b = [1.0, 0.6, 0.4], [2.0, 1.5, 0.3]
    rows = labelled_rows(size_a, size_b, 2000, 3)
    args = [rows[k] for k in KEYS]
    c = box_box(*args)
    s = box_box(*(args[3:] + args[:3]))
    fields = {"normal": s.normal.copy(), "feature_a": s.feature_a, "feature_b": s.feature_b,
              "contact_type_code": s.contact_type_code, "axis": s.axis}
    unswap(fields)
    same = fields["contact_type_code"] == c.contact_type_code
    assert same.mean() > 0.99  # the solver's tie rule prefers A's faces: rare differences
    for name in ("feature_a", "feature_b", "axis"):
        assert (fields[name][same] == getattr(c, name)[same]).mean() > 0.99
    np.testing.assert_allclose(fields["normal"][same & c.colliding],
                               c.normal[same & c.colliding], atol=1e-9)


def test_pair_table_matches_sizes_within_tolerance_and_swapped():
    table = PairTable([([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]), ([1.0, 1.0, 1.0], [1.0, 1.0, 1.0]),
                       ([4.0, 5.0, 6.0], [7.0, 7.0, 7.0])])
    assert table.match_one([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]) == 0
    assert table.match_one([4.0, 5.0, 6.0], [1.0, 2.0, 3.0]) == 1
    assert table.match_one([1.0, 1.0, 1.0 + 5e-7], [1.0, 1.0, 1.0]) == 2
    assert table.match_one([1.0, 1.0, 1.0 + 5e-6], [1.0, 1.0, 1.0]) == UNSUPPORTED
    assert table.match_one([7.0, 7.0, 7.0], [4.0, 5.0, 6.0]) == 5
    size_a = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [1.0, 1.0, 1.0], [9.0, 9.0, 9.0]])
    size_b = np.array([[4.0, 5.0, 6.0], [1.0, 2.0, 3.0 * (1 + 1e-7)], [1.0, 1.0, 1.0],
                       [1.0, 1.0, 1.0]])
    codes = table.match(size_a, size_b)
    np.testing.assert_array_equal(codes, [0, 1, 2, UNSUPPORTED])
    assert table.match(size_a[:1], size_b[:1]) == 0
    assert table.match(np.repeat(size_a[:1], 3, 0), size_b[:1]) == 0
    parts = groups(codes, 4)
    assert [(c, r.tolist()) for c, r in parts] == [(-1, [3]), (0, [0]), (1, [1]), (2, [2])]
    assert groups(np.zeros(5, np.int64), 5) == [(0, None)]


def test_a_direct_match_wins_over_a_swapped_one():
    table = PairTable([([1.0, 1.0, 1.0], [2.0, 2.0, 2.0]), ([2.0, 2.0, 2.0], [1.0, 1.0, 1.0])])
    assert table.match_one([2.0, 2.0, 2.0], [1.0, 1.0, 1.0]) == 2
    assert table.match_one([1.0, 1.0, 1.0], [2.0, 2.0, 2.0]) == 0
