"""The compound pairs of a bundle (manifest ``compound_pairs["a/b"]``, laid out in
:mod:`impactnet.models.bundle.compound_format`) as verified served models: each group's
:class:`~impactnet.models.learned.compound.classifier.GroupClassifier` and each committee
region's :class:`~impactnet.models.learned.compound.experts.RegionCommittee`.

Every MLP an entry names must exist with the inputs and outputs its role needs; part indices and
region codes must be in range. Anything else raises
:class:`impactnet.models.bundle.manifest.BundleError`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from impactnet.models.bundle.compound_format import (
    EXPERT_COMMITTEE,
    EXPERT_EXACT_PART,
    GROUP_INPUTS,
    LABEL_OUTPUTS,
    PART_CONTACT_OUTPUTS,
)
from impactnet.models.bundle.manifest import BundleError, decision_of, finite_numbers
from impactnet.models.learned.compound.classifier import GroupClassifier
from impactnet.models.learned.compound.experts import N_EXPERT_OUTPUTS, RegionCommittee
from impactnet.models.learned.compound.groups import N_GROUP_FEATURES, PartGroup
from impactnet.models.learned.compound.regions import valid_region


@dataclass(frozen=True)
class CompoundPairModels:
    """The learned path of one compound pair, verified."""

    key: str  # "a/b"
    serve: str  # "learned" or "exact-only"
    decision: dict  # the manifest's decision block (figures behind `serve`)
    parts_a: tuple[str, ...]  # A's part names the models were trained on
    parts_b: tuple[str, ...]
    classifiers: tuple[GroupClassifier, ...] = ()  # one per group (empty: exact-only)
    committees: dict = field(default_factory=dict)  # (i, j, code) -> RegionCommittee
    regions: dict = field(default_factory=dict)  # "i/j/code" -> manifest entry (expert, ...)


def _finite(value, count: int, what: str) -> np.ndarray:
    """``value`` as ``(count,)`` finite float64 values, else BundleError naming ``what``."""
    return np.asarray(finite_numbers(value, count, what), np.float64)


def _mlp(name, mlps: dict, outputs: str, n_out: int, what: str):
    """The MLP ``name`` of ``mlps`` if it maps the group features to ``n_out`` values of the
    version ``outputs``."""
    if not isinstance(name, str) or name not in mlps:
        raise BundleError(f"{what}: no MLP {name!r} in the bundle")
    spec = mlps[name].spec
    if (spec.inputs != GROUP_INPUTS or spec.layers[0] != N_GROUP_FEATURES
            or spec.outputs != outputs or spec.layers[-1] != n_out):
        raise BundleError(f"{what}: MLP {name!r} must map {GROUP_INPUTS} ({N_GROUP_FEATURES}) "
                          f"to {n_out} {outputs}")
    return mlps[name]


def _group(entry, mlps, n_a: int, n_b: int, what: str) -> GroupClassifier:
    """The classifier of one ``groups[k]`` entry of a pair whose bodies have ``n_a`` and
    ``n_b`` parts."""
    if not isinstance(entry, dict):
        raise BundleError(f"{what}: expected an object")
    labels = np.asarray(entry.get("labels"), dtype=np.int64).reshape(-1, 2)
    if len(labels) and ((labels[:, 0] < 0) | (labels[:, 0] >= n_a) | (labels[:, 1] < 0)
                        | (labels[:, 1] >= n_b)).any():
        raise BundleError(f"{what}.labels: part index out of range")
    group = PartGroup(str(entry.get("name")), tuple(int(k) for k in entry.get("parts_a", ())),
                      tuple(int(k) for k in entry.get("parts_b", ())),
                      tuple(_finite(entry.get("centre_a"), 3, f"{what}.centre_a")),
                      tuple(_finite(entry.get("centre_b"), 3, f"{what}.centre_b")))
    slots = _region_slots(entry.get("regions", []), len(labels), what)
    mlp = None
    if len(labels):
        mlp = _mlp(entry.get("classifier"), mlps, LABEL_OUTPUTS, len(labels) + len(slots),
                   f"{what}.classifier")
    temperature, candidate_min = (float(entry.get(k, math.nan))
                                  for k in ("temperature", "candidate_min"))
    if not temperature > 0 or not 0.0 < candidate_min < 1.0:
        raise BundleError(f"{what}: temperature > 0 and 0 < candidate_min < 1 required")
    mirror = tuple(float(v) for v in _finite(entry.get("mirror", [1.0, 1.0, 1.0]), 3,
                                             f"{what}.mirror"))
    if any(abs(v) != 1.0 for v in mirror):
        raise BundleError(f"{what}.mirror: each entry +1 or -1")
    return GroupClassifier(group, labels, slots[:, 0], slots[:, 1], mlp, temperature,
                           candidate_min,
                           _finite(entry.get("domain_lo"), N_GROUP_FEATURES,
                                   f"{what}.domain_lo"),
                           _finite(entry.get("domain_hi"), N_GROUP_FEATURES,
                                   f"{what}.domain_hi"), mirror)


def _region_slots(value, n_labels: int, what: str) -> np.ndarray:
    """(r, 2) int64 region slots (label, code) of a group: each label has at least one, in
    ascending label order, and every code is a region."""
    try:
        slots = np.asarray(value, dtype=np.int64).reshape(-1, 2)
    except (TypeError, ValueError):
        raise BundleError(f"{what}.regions: a list of [label, region code] pairs") from None
    if (np.any(np.diff(slots[:, 0]) < 0)
            or not np.array_equal(np.unique(slots[:, 0]), np.arange(n_labels))):
        raise BundleError(f"{what}.regions: every label needs region slots, in label order")
    if not all(valid_region(c) for c in slots[:, 1]):
        raise BundleError(f"{what}.regions: a code is not a contact region")
    return slots


def _committee(key: str, entry: dict, mlps, parts_a, parts_b, what: str,
               ) -> RegionCommittee:
    """The committee of the region entry ``regions["i/j/code"]`` (``key``)."""
    i, j, code = (int(v) for v in key.split("/"))
    if not (0 <= i < len(parts_a) and 0 <= j < len(parts_b)) or not valid_region(code):
        raise BundleError(f"{what}: part index or region code out of range")
    members = entry.get("members")
    if not isinstance(members, list) or not members:
        raise BundleError(f"{what}.members: a non-empty list of MLP names")
    frame = entry.get("frame") or {}
    return RegionCommittee(
        i, j, code, PartGroup(key, (i,), (j,),
                        tuple(_finite(frame.get("centre_a"), 3, f"{what}.frame")),
                        tuple(_finite(frame.get("centre_b"), 3, f"{what}.frame"))),
        tuple(_mlp(m, mlps, PART_CONTACT_OUTPUTS, N_EXPERT_OUTPUTS, f"{what}.members")
              for m in members),
        float(entry["sure_min"]), float(entry["normal_spread_max_deg"]),
        float(entry["depth_spread_max_m"]), int(entry["contact_type_code"]),
        int(entry["feature_a"]), int(entry["feature_b"]))


def compound_pair_models(key: str, entry, mlps: dict) -> CompoundPairModels:
    """The verified models of manifest entry ``compound_pairs[key]``, its MLPs looked up in
    ``mlps`` (name -> MLP)."""
    what = f"compound_pairs[{key!r}]"
    if not isinstance(entry, dict) or not isinstance(entry.get("decision"), dict):
        raise BundleError(f"{what}: expected an object with a `decision`")
    serve, decision = decision_of(entry["decision"], what)
    parts_a, parts_b = (tuple(str(n) for n in entry.get(s, ())) for s in ("parts_a", "parts_b"))
    groups = entry.get("groups", [])
    regions = entry.get("regions", {})
    if not isinstance(groups, list) or not isinstance(regions, dict):
        raise BundleError(f"{what}: `groups` is a list and `regions` an object")
    if serve == "learned" and not groups:
        raise BundleError(f"{what}: a learned pair needs its groups")
    classifiers = tuple(_group(g, mlps, len(parts_a), len(parts_b), f"{what}.groups[{k}]",
                               ) for k, g in enumerate(groups))
    committees = {}
    for region, block in regions.items():
        where = f"{what}.regions[{region!r}]"
        if not isinstance(block, dict) or block.get("expert") not in (EXPERT_COMMITTEE,
                                                                       EXPERT_EXACT_PART):
            raise BundleError(f"{where}.expert: {EXPERT_COMMITTEE!r} or {EXPERT_EXACT_PART!r}")
        try:
            if block["expert"] == EXPERT_COMMITTEE:
                c = _committee(region, block, mlps, parts_a, parts_b, where)
                committees[(c.part_a, c.part_b, c.region)] = c
        except (KeyError, TypeError, ValueError) as exc:
            raise BundleError(f"{where}: {exc}") from None
    return CompoundPairModels(key, serve, decision, parts_a, parts_b, classifiers,
                              committees, regions)
