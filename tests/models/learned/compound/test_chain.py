"""The learned path of compound pairs (``CompoundChain``) with hand-made models: candidates go
to the exact part-pair solver (the oracle's answer when every touching pair is a candidate),
rows outside the classifier's domain go to the oracle, a sure region with a committee is
answered by it (in the world frame, predictor ``learned``) only in the coarse region the
classifier names, and big batches are answered in blocks as one."""
import numpy as np

from impactnet.models.compound import compound_answer, container, spreader
from impactnet.models.compound.oracle import ORACLE_CHUNK
from impactnet.models.geometry.rotations import quaternion_multiply, quaternion_to_matrix
from impactnet.models.learned.compound.chain import CompoundChain
from impactnet.models.learned.compound.classifier import GroupClassifier
from impactnet.models.learned.compound.experts import N_EXPERT_OUTPUTS, RegionCommittee
from impactnet.models.learned.compound.groups import (
    N_GROUP_FEATURES,
    PartGroup,
    part_groups,
)
from impactnet.models.learned.mlp import MLP, MLPSpec

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
#: Region codes: face-face, A's +z face on B's -z face; edge-edge, A's +x edge on B's -y.
TOP_ON_BOTTOM, EDGE_SIDE = 6 * 36 + 4 * 6 + 5, 3 * 36 + 0 * 6 + 3


def _constant_mlp(values) -> MLP:
    """An MLP whose output is ``values`` whatever the input (zero weights)."""
    values = np.asarray(values, np.float32)
    spec = MLPSpec("tanh", (N_GROUP_FEATURES, 4, len(values)), "group-pose-v1", "x")
    return MLP(spec, [np.zeros((4, N_GROUP_FEATURES)), np.zeros((len(values), 4))],
               [np.zeros(4), np.zeros(len(values))], np.zeros(N_GROUP_FEATURES),
               np.ones(N_GROUP_FEATURES), values, np.ones(len(values)))


def _every_pair_chain(parts_a, parts_b, lo=-np.inf, hi=np.inf, committees=None,
                      named=TOP_ON_BOTTOM):
    """A chain whose one classifier names every part pair with probability ~1, each in the
    coarse region ``named`` (of two slots per label: TOP_ON_BOTTOM and EDGE_SIDE)."""
    labels = np.array([(i, j) for i in range(len(parts_a)) for j in range(len(parts_b))])
    body = part_groups(parts_a, parts_b)[-1]
    v = len(labels)
    slot_label, slot_code = np.repeat(np.arange(v), 2), np.tile([TOP_ON_BOTTOM, EDGE_SIDE], v)
    slot_logit = np.where(slot_code == named, 3.0, 0.0)
    clf = GroupClassifier(body, labels, slot_label, slot_code,
                          _constant_mlp(np.r_[np.full(v, 20.0), slot_logit]), 1.0, 0.01,
                          np.full(N_GROUP_FEATURES, lo), np.full(N_GROUP_FEATURES, hi))
    return CompoundChain("a/b", tuple(parts_a), tuple(parts_b), (clf,), committees or {})


def _landing(n, seed):
    rng = np.random.default_rng(seed)
    position = np.c_[rng.uniform(-0.02, 0.02, (n, 2)),
                     2.591 / 2 + 0.4 + 0.004 - rng.uniform(0, 0.006, n)]
    return position, np.tile(IDENTITY, (n, 1))


def test_naming_every_part_pair_gives_the_oracles_summary_in_any_body_pose():
    parts_a, parts_b = container("40ft", detail=2), spreader("40ft", sides=8)
    chain = _every_pair_chain(parts_a, parts_b)
    position, quaternion = _landing(40, 3)
    shift, turn = np.array([3.0, -2.0, 1.0]), np.array([np.cos(0.3), 0.0, 0.0, np.sin(0.3)])
    rot = quaternion_to_matrix(turn)[0]  # both bodies moved and turned together
    world_b = shift + position @ rot.T

    q_b = quaternion_multiply(np.tile(turn, (40, 1)), quaternion)
    got = chain.answer(shift, turn, world_b, q_b)
    want = compound_answer(parts_a, shift, turn, parts_b, world_b, q_b)
    assert set(got.predictor) == {"exact-part"}
    np.testing.assert_array_equal(got.parts.offsets, want.parts.offsets)
    np.testing.assert_allclose(got.summary.depth, want.summary.depth, atol=1e-15)
    np.testing.assert_allclose(got.summary.point, want.summary.point, atol=1e-12)
    np.testing.assert_allclose(got.summary.normal, want.summary.normal, atol=1e-12)


def test_rows_outside_the_classifiers_domain_go_to_the_oracle_in_auto_only():
    parts_a, parts_b = container("40ft", detail=1), spreader("40ft", sides=8)
    position, quaternion = _landing(6, 4)
    chain = _every_pair_chain(parts_a, parts_b, lo=-1e-3, hi=1e-3)  # nothing is inside
    auto = chain.answer(np.zeros(3), IDENTITY, position, quaternion)
    assert set(auto.predictor) == {"oracle"}
    committee = chain.answer(np.zeros(3), IDENTITY, position, quaternion, fallback=False)
    assert set(committee.predictor) == {"exact-part"}
    np.testing.assert_allclose(auto.summary.depth, committee.summary.depth, atol=1e-15)


def _committee_of_first_contact(parts_a, parts_b, position, quaternion):
    """((i, j), a committee of region (i, j, TOP_ON_BOTTOM)) of the oracle's first contact."""
    oracle = compound_answer(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion)
    i, j = int(oracle.parts.part_a[0]), int(oracle.parts.part_b[0])
    frame = PartGroup("r", (i,), (j,), (0.1, 0.2, 0.3), (0.0, 0.0, 0.0))
    outputs = [0.001, 0.0, 0.0, 2.0, 0.0, 0.0, 0.05, 1e-6]  # depth, normal, offset, pressure
    members = tuple(_constant_mlp(outputs) for _ in range(2))
    assert N_EXPERT_OUTPUTS == len(outputs)
    return (i, j), RegionCommittee(i, j, TOP_ON_BOTTOM, frame, members, 0.5, 1.0, 1e-4, 6, 5,
                                   0)


def test_a_committee_answers_only_the_coarse_region_the_classifier_names():
    parts_a, parts_b = container("40ft", detail=1), spreader("40ft", sides=8)
    position, quaternion = _landing(5, 5)
    (i, j), committee = _committee_of_first_contact(parts_a, parts_b, position, quaternion)
    chain = _every_pair_chain(parts_a, parts_b, committees={(i, j, TOP_ON_BOTTOM): committee},
                              named=EDGE_SIDE)  # the classifier names another region
    got = chain.answer(np.zeros(3), IDENTITY, position, quaternion)
    want = compound_answer(parts_a, np.zeros(3), IDENTITY, parts_b, position, quaternion)
    assert set(got.predictor) == {"exact-part"}
    np.testing.assert_allclose(got.summary.depth, want.summary.depth, atol=1e-15)
    pose, part_a, part_b, _, region, _ = chain.candidates(position, np.tile(np.eye(3), (5, 1, 1)))
    assert set(region) == {EDGE_SIDE} and len(pose) == 5 * len(parts_a) * len(parts_b)


def test_a_sure_region_with_a_committee_is_answered_by_it_in_the_world_frame():
    parts_a, parts_b = container("40ft", detail=1), spreader("40ft", sides=8)
    position, quaternion = _landing(5, 5)
    (i, j), committee = _committee_of_first_contact(parts_a, parts_b, position, quaternion)
    chain = _every_pair_chain(parts_a, parts_b, committees={(i, j, TOP_ON_BOTTOM): committee})
    shift, turn = np.array([1.0, 2.0, 3.0]), np.array([np.cos(0.5), np.sin(0.5), 0.0, 0.0])
    rot = quaternion_to_matrix(turn)[0]

    got = chain.answer(shift, turn, shift + position @ rot.T,
                       quaternion_multiply(np.tile(turn, (5, 1)), quaternion))
    rows = np.flatnonzero((got.parts.part_a == i) & (got.parts.part_b == j))
    touching = np.unique(got.parts.pose[rows])
    assert set(got.predictor[touching]) == {"learned"}
    c = got.parts.contacts
    np.testing.assert_allclose(c.depth[rows], 0.001, rtol=1e-6)
    np.testing.assert_allclose(c.normal[rows], np.tile(rot[:, 2], (len(rows), 1)), atol=1e-7)
    np.testing.assert_allclose(c.point[rows], np.tile(shift + rot @ [0.1, 0.2, 0.35],
                                                      (len(rows), 1)), atol=1e-6)


def test_a_batch_larger_than_a_block_is_answered_as_its_blocks():
    parts_a, parts_b = container("20ft", detail=1), container("20ft", detail=1)
    chain = _every_pair_chain(parts_a, parts_b)
    n = ORACLE_CHUNK + 7
    rng = np.random.default_rng(6)
    position = np.c_[rng.uniform(-0.01, 0.01, (n, 2)), 2.591 - rng.uniform(0, 0.002, n)]
    got = chain.answer(np.zeros(3), IDENTITY, position, IDENTITY)
    want = compound_answer(parts_a, np.zeros(3), IDENTITY, parts_b, position, IDENTITY)
    assert len(got.predictor) == n
    np.testing.assert_array_equal(got.parts.offsets, want.parts.offsets)
    np.testing.assert_allclose(got.summary.depth, want.summary.depth, atol=1e-15)
