"""``auto`` for compound pairs (issue #21, step 3): classifier, experts, oracle.

For N poses of one compound pair (body A, body B, both anywhere in the world):

1. B's pose in A's frame; each group's classifier
   (:class:`impactnet.models.learned.compound.classifier.GroupClassifier`) gives its labels'
   probabilities. A row outside any classifier's domain is *unsure*.
2. With ``fallback`` (mode ``auto``), unsure rows go to the exact compound oracle
   (predictor ``oracle``). Without it (mode ``committee``) the chain answers them too.
3. Every candidate label (probability >= the group's ``candidate_min``) goes to the expert of the
   coarse region the classifier names for it (:mod:`impactnet.models.learned.compound.regions`): the
   region's committee where training chose one and the classifier is sure (probability >= its
   ``sure_min``) and the members agree, else the exact part-pair solver, which also drops candidates
   that do not touch.
4. The part contacts of all sources, pose-major, and the body summary of docs/design.md.

Each row names its predictor: ``oracle`` (fallback), ``learned`` (at least one part contact
from a committee) or ``exact-part`` (the classifier chose the part pairs, the exact part-pair
solver answered them).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from impactnet.models.compound.oracle import (
    ORACLE_CHUNK,
    PartContacts,
    compound_contacts,
    concatenated,
    joined,
    part_pair_contacts,
)
from impactnet.models.compound.summary import BodySummary, summarise
from impactnet.models.contacts import Contacts
from impactnet.models.geometry.rotations import quaternion_to_matrix, validate_quaternion
from impactnet.models.learned.compound.classifier import GroupClassifier
from impactnet.models.learned.compound.experts import RegionCommittee
from impactnet.models.learned.compound.groups import relative_pose
from impactnet.models.learned.compound.kernel_classify import (
    ClassifierSet,
    classifier_set,
    classify,
)

#: Predictor names of a compound row.
LEARNED, EXACT_PART, ORACLE = "learned", "exact-part", "oracle"


@dataclass(frozen=True)
class ChainAnswer:
    """The chain's answer for N poses."""

    parts: PartContacts  # the part contacts of every pose, pose-major
    summary: BodySummary  # the body-level summary per pose
    predictor: np.ndarray  # (n,) str: ORACLE, LEARNED or EXACT_PART


@dataclass(frozen=True)
class CompoundChain:
    """The learned path of one compound pair."""

    key: str  # "a/b"
    parts_a: tuple  # A's parts (the scene's)
    parts_b: tuple  # B's parts
    classifiers: tuple[GroupClassifier, ...]  # one per group
    committees: dict  # (part_a, part_b, region code) -> RegionCommittee, the regions that
    # chose one

    @cached_property
    def compiled(self) -> tuple[ClassifierSet, np.ndarray, np.ndarray]:
        """(the classifiers as the kernel takes them, every label's (A's part, B's part) (V, 2)
        and its classifier's ``candidate_min`` (V,)), labels in classifier order."""
        labels = [np.asarray(clf.labels, np.int64).reshape(-1, 2) for clf in self.classifiers]
        floor = [np.full(len(clf.labels), clf.candidate_min) for clf in self.classifiers]
        return (classifier_set(self.classifiers), np.concatenate(labels),
                np.concatenate(floor))

    def candidates(self, position, rotation):
        """(pose (k,), part_a (k,), part_b (k,), probability (k,), region (k,), inside (n,)
        bool) of B's poses in A's frame: every candidate label, its coarse region, pose-major
        (labels in classifier order within a pose)."""
        classifiers, labels, floor = self.compiled
        found = classify(classifiers, position, rotation)
        pose, label = np.nonzero(found.probability >= floor)
        return (pose, labels[label, 0], labels[label, 1], found.probability[pose, label],
                found.region[pose, label], found.inside)

    def answer(self, position_a, quaternion_a, position_b, quaternion_b,
               fallback: bool = True) -> ChainAnswer:
        """The chain's answer (module docstring) for poses of shape (3,)/(4,) or (n, 3)/(n, 4)
        (metres, (w, x, y, z) quaternions), broadcast against each other."""
        q_a = validate_quaternion(np.atleast_2d(np.asarray(quaternion_a, np.float64)))
        q_b = validate_quaternion(np.atleast_2d(np.asarray(quaternion_b, np.float64)))
        p_a = np.atleast_2d(np.asarray(position_a, np.float64))
        p_b = np.atleast_2d(np.asarray(position_b, np.float64))
        n = max(len(p_a), len(p_b), len(q_a), len(q_b))
        p_a, p_b = np.broadcast_to(p_a, (n, 3)), np.broadcast_to(p_b, (n, 3))
        q_a, q_b = np.broadcast_to(q_a, (n, 4)), np.broadcast_to(q_b, (n, 4))
        if n > ORACLE_CHUNK:  # blocks of poses, as the oracle: the working set stays in cache
            blocks = [self._block(p_a[s:s + ORACLE_CHUNK], q_a[s:s + ORACLE_CHUNK],
                                  p_b[s:s + ORACLE_CHUNK], q_b[s:s + ORACLE_CHUNK], fallback)
                      for s in range(0, n, ORACLE_CHUNK)]
            parts = joined([b[0] for b in blocks])
            return ChainAnswer(parts, summarise(parts),
                               np.concatenate([b[1] for b in blocks]))
        parts, predictor = self._block(p_a, q_a, p_b, q_b, fallback)
        return ChainAnswer(parts, summarise(parts), predictor)

    def _block(self, p_a, q_a, p_b, q_b, fallback: bool):
        """(PartContacts, predictor (n,)) of one block of n poses (arrays (n, 3) / (n, 4))."""
        n = len(p_a)
        rot_a = quaternion_to_matrix(q_a)
        position, rotation = relative_pose(p_a, rot_a, p_b, quaternion_to_matrix(q_b))
        pose, part_a, part_b, prob, region, inside = self.candidates(position, rotation)
        unsure = ~inside if fallback else np.zeros(n, bool)
        keep = ~unsure[pose]
        pose, part_a, part_b, prob = pose[keep], part_a[keep], part_b[keep], prob[keep]
        pieces = []
        for key, rows in self._committee_mask(part_a, part_b, region[keep], prob).items():
            committee = self.committees[key]
            at = pose[rows]
            depth, normal, point, pressure, usable = committee.predict(position[at],
                                                                       rotation[at])
            done = rows[usable]
            pieces.append((pose[done], part_a[done], part_b[done], _world(
                committee, depth[usable], normal[usable], point[usable], pressure[usable],
                prob[done], p_a[pose[done]], rot_a[pose[done]])))
            prob[done] = -1.0  # answered: not for the exact part-pair solver
        learned = np.zeros(n, bool)
        for piece in pieces:  # so far: the committees' answers
            learned[piece[0]] = True
        exact = prob >= 0.0
        found = part_pair_contacts(self.parts_a, p_a, q_a, self.parts_b, p_b, q_b, pose[exact],
                                   part_a[exact], part_b[exact])
        pieces.append((found.pose, found.part_a, found.part_b, found.contacts))
        if unsure.any():
            rows = np.flatnonzero(unsure)
            oracle = compound_contacts(self.parts_a, p_a[rows], q_a[rows], self.parts_b,
                                       p_b[rows], q_b[rows])
            pieces.append((rows[oracle.pose], oracle.part_a, oracle.part_b, oracle.contacts))
        parts = merged(pieces, n)
        return parts, np.where(unsure, ORACLE, np.where(learned, LEARNED, EXACT_PART))

    def _committee_mask(self, part_a, part_b, region, prob) -> dict:
        """(i, j, region) -> candidate rows in that region that its committee is sure enough
        to answer."""
        out = {}
        for (i, j, code), committee in self.committees.items():
            rows = np.flatnonzero((part_a == i) & (part_b == j) & (region == code)
                                  & (prob >= committee.sure_min))
            if len(rows):
                out[(i, j, code)] = rows
        return out


def _world(committee: RegionCommittee, depth, normal, point, pressure, confidence, p_a,
           rot_a) -> Contacts:
    """A committee's answers (A's frame) as world-frame Contacts rows."""
    k = len(depth)
    return Contacts(
        colliding=np.ones(k, bool), normal=np.einsum("kij,kj->ki", rot_a, normal), depth=depth,
        point=p_a + np.einsum("kij,kj->ki", rot_a, point),
        contact_type_code=np.full(k, committee.contact_type_code, np.int8),
        feature_a=np.full(k, committee.feature_a, np.int32),
        feature_b=np.full(k, committee.feature_b, np.int32), axis=np.full(k, -1, np.int8),
        manifold_points=np.zeros((k, 8, 3)), manifold_depths=np.zeros((k, 8)),
        manifold_count=np.zeros(k, np.int8), confidence=confidence,
        predictor=np.full(k, LEARNED), pressure=pressure)


def merged(pieces, n: int) -> PartContacts:
    """One pose-major PartContacts of n poses from pieces ``(pose, part_a, part_b,
    Contacts)``."""
    pose = np.concatenate([p[0] for p in pieces]).astype(np.int64)
    order = np.argsort(pose, kind="stable")
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(pose, minlength=n), out=offsets[1:])
    return PartContacts(pose[order],
                        np.concatenate([p[1] for p in pieces]).astype(np.int16)[order],
                        np.concatenate([p[2] for p in pieces]).astype(np.int16)[order],
                        concatenated([p[3] for p in pieces], order), offsets)


def chain_of(models, parts_a, parts_b) -> CompoundChain:
    """The chain of a bundle's compound pair models
    (:class:`impactnet.models.learned.compound.bundle_pairs.CompoundPairModels`) over the scene's
    parts."""
    return CompoundChain(models.key, tuple(parts_a), tuple(parts_b), models.classifiers,
                         dict(models.committees))
