"""The compound pairs of a bundle (manifest ``compound_pairs``, issue #21).

Entry ``compound_pairs["a/b"]``::

    {"decision": {"serve": "learned" | "exact-only", "figures": {...}, ...},
     "parts_a": [A's part names], "parts_b": [B's part names],
     "groups": [{"name", "parts_a", "parts_b", "centre_a", "centre_b", "labels": [[i, j], ...],
                 "regions": [[label index, region code], ...] (label ascending),
                 "classifier": MLP name | null, "temperature", "candidate_min",
                 "domain_lo", "domain_hi", "mirror": [+-1, +-1, 1] (optional)}, ...],
     "regions": {"i/j/code": {"expert": "committee" | "exact-part", "figures": {...},
                              "region": {"type", "face_a", "face_b"},
                              committee only: "members", "sure_min", "normal_spread_max_deg",
                              "depth_spread_max_m", "contact_type_code", "feature_a",
                              "feature_b"}}}

Region codes are the learned side's (contact type x the two parts' bounding-box faces,
:mod:`impactnet.models.learned.compound.regions`). An exact-only pair needs no groups and no
regions. The MLPs it names are declared in the manifest's ``mlps`` with the inputs
:data:`GROUP_INPUTS`; a classifier gives one logit per label, then one per region slot
(:data:`LABEL_OUTPUTS`), a committee member
:data:`impactnet.models.learned.compound.experts.N_EXPERT_OUTPUTS` values
(:data:`PART_CONTACT_OUTPUTS`).

This module is the vocabulary of those entries (the names the manifest uses), shared by the
trainers that write them and :mod:`impactnet.models.learned.compound.bundle_pairs`, which
verifies an entry and builds its served models (anything else raises
:class:`impactnet.models.bundle.manifest.BundleError`).
"""
from __future__ import annotations

__all__ = ["EXPERT_COMMITTEE", "EXPERT_EXACT_PART", "GROUP_INPUTS", "LABEL_OUTPUTS",
           "PART_CONTACT_OUTPUTS"]

#: The inputs of every compound MLP: a group's features.
GROUP_INPUTS = "group-pose-v1"
#: A classifier's outputs: one logit per label, then one per region slot.
LABEL_OUTPUTS = "part-labels-regions-v1"
#: A committee member's outputs: one part contact.
PART_CONTACT_OUTPUTS = "part-contact-v1"
#: A region's ``expert``: a committee of MLPs, or the exact part-pair solver.
EXPERT_COMMITTEE, EXPERT_EXACT_PART = "committee", "exact-part"
