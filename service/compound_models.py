"""The learned path of compound pairs in the service (issue #21): the chains a bundle serves,
their smoke test at load, and how GET /v1/models describes them.

A bundle's ``compound_pairs`` (:mod:`impactnet.models.bundle.compound_format`) become one
:class:`impactnet.models.learned.compound.CompoundChain` per pair recorded ``learned``, over the
served scene's parts (the scene hash check has made sure they are the ones trained on). Pairs
recorded exact-only have no chain: every mode answers them with the oracle.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound import compound_answer
from impactnet.models.compound.parts import bounds
from impactnet.models.learned.bundle_loader import Bundle
from impactnet.models.learned.compound import chain_of
from impactnet.models.learned.compound.chain import EXACT_PART, LEARNED, ORACLE
from impactnet.service.smoke import SmokeTestFailed

#: The decision figures of a compound pair that GET /v1/models shows (the manifest has all).
COMPOUND_FIGURES = ("speedup_n1", "speedup_batch", "fallback_share", "missed_share",
                    "oracle_n1_us", "oracle_batch_us_per_pose", "batch_poses")
#: Smoke poses: B's envelope is set down on A's, its base this far (m) into A's top, shifted
#: up to this far (m) sideways: the stacking and landing poses the pairs are trained on.
SMOKE_DEPTH_M, SMOKE_SHIFT_M = 5e-4, 0.02


def compound_chains(bundle: Bundle, scene) -> dict:
    """"a/b" -> chain of every compound pair that ``bundle`` serves learned (``scene``: the
    :class:`impactnet.service.scene.SceneView`)."""
    chains = {}
    for key, models in bundle.compound.items():
        if models.serve != "learned":
            continue
        a, b = key.split("/")
        parts_a, parts_b = scene.compound_parts.get(a), scene.compound_parts.get(b)
        if parts_a is None or parts_b is None:
            continue  # a pair of the bundle that the served scene does not have
        chains[key] = chain_of(models, parts_a, parts_b)
    return chains


def _smoke_poses(chain, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    hi_a = np.max([bounds(p)[1] for p in chain.parts_a], axis=0)
    lo_b = np.min([bounds(p)[0] for p in chain.parts_b], axis=0)
    position = np.zeros((n, 3))
    position[:, 2] = hi_a[2] - lo_b[2] - SMOKE_DEPTH_M
    position[:, :2] = rng.uniform(-SMOKE_SHIFT_M, SMOKE_SHIFT_M, (n, 2))
    return position, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))


def compound_smoke(chains: dict, n: int) -> dict:
    """Run every chain on ``n`` poses in mode auto and committee, and on one pose; check the
    answers' shapes, finiteness and predictor names; report the agreement of the summary
    depth with the oracle (SmokeTestFailed on a broken answer)."""
    report = {}
    rng = np.random.default_rng(0)
    for key, chain in chains.items():
        position, quaternion = _smoke_poses(chain, max(1, n), rng)
        identity = (np.zeros(3), np.array([1.0, 0, 0, 0]))
        oracle = compound_answer(chain.parts_a, *identity, chain.parts_b, position, quaternion)
        figures = {}
        for mode, fallback in (("auto", True), ("committee", False)):
            try:
                answer = chain.answer(*identity, position, quaternion, fallback=fallback)
                one = chain.answer(*identity, position[0], quaternion[0], fallback=fallback)
            except Exception as exc:  # noqa: BLE001 - any failure is the bundle's
                raise SmokeTestFailed(f"compound pair {key}, mode {mode}: "
                                      f"{type(exc).__name__}: {exc}") from exc
            s = answer.summary
            if (len(s.depth) != len(position) or len(one.summary.depth) != 1
                    or not all(np.isfinite(v).all() for v in (s.depth, s.normal, s.point))
                    or not set(answer.predictor) <= {LEARNED, EXACT_PART, ORACLE}):
                raise SmokeTestFailed(f"compound pair {key}, mode {mode}: a malformed answer")
            figures[mode] = {
                "answered_by": {str(p): int((answer.predictor == p).sum())
                                for p in np.unique(answer.predictor)},
                "depth_max_abs_error_m": float(np.abs(s.depth - oracle.summary.depth).max())}
        report[key] = figures
    return report


def describe_compound(bundle: Bundle) -> dict:
    """The compound pairs as GET /v1/models shows them: serve, the key figures behind it, and
    how many regions took a committee."""
    out = {}
    for key, models in bundle.compound.items():
        figures = models.decision.get("figures", {})
        experts = [r.get("expert") for r in models.regions.values()]
        out[key] = {"serve": models.serve,
                    "modes": ["auto", "committee"] if models.serve == "learned" else [],
                    "reasons": models.decision.get("reasons", []),
                    "decision": {k: figures.get(k) for k in COMPOUND_FIGURES},
                    "regions": {"committee": experts.count("committee"),
                                "exact-part": experts.count("exact-part")},
                    "groups": len(models.classifiers)}
    return out
