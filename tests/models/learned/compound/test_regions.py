"""Coarse contact regions (issue #21's granularity): the box face a direction leaves through,
a level stack touching top face on bottom face, the oracle's regions of a mirrored pose being
the mirrored regions (the canonical frame of the pooled corners), and a pooled classifier
naming its regions in its own corner's frame."""
import numpy as np
import pytest

from impactnet.models.compound import compound_answer, container, spreader
from impactnet.models.geometry.rotations import matrix_to_quaternion, quaternion_to_matrix
from impactnet.models.learned.compound.classifier import GroupClassifier
from impactnet.models.learned.compound.groups import (
    CORNER_MIRRORS,
    N_GROUP_FEATURES,
    mirror_map,
    part_groups,
)
from impactnet.models.learned.compound.regions import (
    CODES_PER_TYPE,
    box_face,
    coarse_regions,
    describe_region,
    mirror_regions,
    valid_region,
)
from impactnet.models.learned.mlp import MLP, MLPSpec

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def test_a_direction_leaves_a_box_through_the_face_of_its_largest_component():
    directions = np.array([[0, 0, 1], [0, 0, -1], [-2, 1, 0], [0.1, 0.3, -0.2], [1, -1e-9, 0]])
    assert box_face(directions).tolist() == [4, 5, 1, 2, 0]


def test_on_a_yawed_body_b_the_face_is_taken_in_bs_own_frame():
    turn = np.array([[[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]])  # B yawed 90°
    # the normal leaves A through +x; on B (yawed) the touched face is +y: -R^T n = (0, 1, 0)
    assert coarse_regions(np.array([6]), np.array([[1.0, 0.0, 0.0]]), turn).tolist() == [
        6 * CODES_PER_TYPE + 0 * 6 + 2]


def test_codes_name_a_type_and_two_faces_and_none_is_no_region():
    code = 6 * CODES_PER_TYPE + 4 * 6 + 5
    assert describe_region(code) == {"type": "face-face", "face_a": "+z", "face_b": "-z"}
    assert valid_region(code) and not valid_region(5) and not valid_region(7 * CODES_PER_TYPE)


def _poses(n, seed, height, tilt_deg):
    """B just below resting height over A, tilted by up to ``tilt_deg`` about random axes."""
    rng = np.random.default_rng(seed)
    position = np.c_[rng.uniform(-0.03, 0.03, (n, 2)), height - rng.uniform(0, 0.004, n)]
    axis = rng.normal(size=(n, 3))
    half = np.radians(rng.uniform(0, tilt_deg, n)) / 2
    return position, np.c_[np.cos(half), np.sin(half)[:, None] * axis
                           / np.linalg.norm(axis, axis=1, keepdims=True)]


def _regions(parts_a, parts_b, position, quaternion):
    """The oracle's part contacts (A at the origin): (pose, part_a, part_b, region codes)."""
    got = compound_answer(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion).parts
    rotation = quaternion_to_matrix(quaternion)[got.pose]
    return (got.pose, got.part_a.astype(int), got.part_b.astype(int),
            coarse_regions(got.contacts.contact_type_code, got.contacts.normal, rotation))


def test_a_level_stack_touches_top_face_on_bottom_face():
    parts = container("20ft", detail=1)
    position, quaternion = _poses(30, 1, 2.591, 0.0)
    _, _, _, codes = _regions(parts, parts, position, quaternion)
    assert len(codes)
    assert {(describe_region(c)["face_a"], describe_region(c)["face_b"]) for c in codes} == {
        ("+z", "-z")}


@pytest.mark.parametrize("corner", ["fr", "al", "ar"])
def test_the_regions_of_a_mirrored_pose_are_the_mirrored_regions(corner):
    parts_a, parts_b = container("40ft", detail=2), spreader("40ft", sides=16)
    mirror = np.asarray(CORNER_MIRRORS[corner])
    map_a, map_b = mirror_map(parts_a, mirror), mirror_map(parts_b, mirror)
    position, quaternion = _poses(60, 2, 2.591 / 2 + 0.4, 3.0)
    rotation = quaternion_to_matrix(quaternion)
    mirrored_q = matrix_to_quaternion(rotation * mirror[:, None] * mirror[None, :])  # M R M
    pose, part_a, part_b, codes = _regions(parts_a, parts_b, position, quaternion)
    m_pose, m_a, m_b, m_codes = _regions(parts_a, parts_b, position * mirror, mirrored_q)
    assert len(codes) > 60
    want = {(int(p), int(map_a[a]), int(map_b[b]), int(c)) for p, a, b, c in
            zip(pose, part_a, part_b, mirror_regions(codes, mirror))}
    assert {tuple(int(v) for v in t) for t in zip(m_pose, m_a, m_b, m_codes)} == want


def test_mirroring_regions_twice_gives_them_back_and_keeps_the_type():
    codes = np.arange(CODES_PER_TYPE, 7 * CODES_PER_TYPE)
    for mirror in CORNER_MIRRORS.values():
        once = mirror_regions(codes, mirror)
        np.testing.assert_array_equal(mirror_regions(once, mirror), codes)
        np.testing.assert_array_equal(once // CODES_PER_TYPE, codes // CODES_PER_TYPE)


def test_a_pooled_corner_names_its_regions_in_its_own_frame():
    group = part_groups(container("40ft", detail=1), spreader("40ft", sides=8))[0]
    plus_x = 6 * CODES_PER_TYPE + 0 * 6 + 1  # face-face, A's +x face on B's -x face
    spec = MLPSpec("tanh", (N_GROUP_FEATURES, 2, 3), "group-pose-v1", "x")
    mlp = MLP(spec, [np.zeros((2, N_GROUP_FEATURES)), np.zeros((3, 2))],
              [np.zeros(2), np.zeros(3)], np.zeros(N_GROUP_FEATURES), np.ones(N_GROUP_FEATURES),
              np.array([20.0, 2.0, 0.0], np.float32), np.ones(3))
    clf = GroupClassifier(group, np.array([[0, 0]]), np.array([0, 0]),
                          np.array([plus_x, plus_x + 1]), mlp, 1.0, 0.01,
                          np.full(N_GROUP_FEATURES, -np.inf), np.full(N_GROUP_FEATURES, np.inf),
                          tuple(CORNER_MIRRORS["al"]))  # mirrored across x
    got = clf.classify(np.zeros((1, 3)), np.eye(3)[None])
    assert describe_region(got.region[0, 0]) == {"type": "face-face", "face_a": "-x",
                                                 "face_b": "+x"}
    np.testing.assert_allclose(got.share[0, 0], 1 / (1 + np.exp(-2.0)), rtol=1e-12)


def test_each_candidate_gets_the_best_of_its_own_labels_slots_however_many():
    group = part_groups(container("20ft", detail=1), container("20ft", detail=1))[-1]
    slot_label = np.array([0, 1, 1, 1, 2])  # 1, 3 and 1 slots
    codes = CODES_PER_TYPE * 6 + np.arange(5)
    slot_logits = np.array([-5.0, 0.0, 4.0, 1.0, -9.0])  # label 1: its second slot wins
    spec = MLPSpec("tanh", (N_GROUP_FEATURES, 2, 8), "group-pose-v1", "x")
    mlp = MLP(spec, [np.zeros((2, N_GROUP_FEATURES)), np.zeros((8, 2))],
              [np.zeros(2), np.zeros(8)], np.zeros(N_GROUP_FEATURES), np.ones(N_GROUP_FEATURES),
              np.r_[np.zeros(3), slot_logits].astype(np.float32), np.ones(8))
    clf = GroupClassifier(group, np.array([[0, 0], [1, 1], [2, 2]]), slot_label, codes, mlp,
                          1.0, 0.01, np.full(N_GROUP_FEATURES, -np.inf),
                          np.full(N_GROUP_FEATURES, np.inf))
    got = clf.classify(np.zeros((2, 3)), np.tile(np.eye(3), (2, 1, 1)))
    for pose in (0, 1):  # every label's region, whichever pose
        np.testing.assert_array_equal(got.region[pose], codes[[0, 2, 4]])  # a lone slot: sure
        np.testing.assert_allclose(got.share[pose, [0, 2]], 1.0)
        np.testing.assert_allclose(got.share[pose, 1], np.exp(4) / np.exp([0.0, 4.0, 1.0]).sum(),
                                   rtol=1e-12)
