"""One pair's models ready to run: everything a predictor's kernel needs, computed once at load
time.

:class:`PairRuntime` holds the pair's lengths (``L``, ``e``), its trained depth domain, its
``auto`` thresholds and its *program*: the two arrays the compiled row function takes
(:mod:`impactnet.models.learned.kernel_pair`, :func:`program`), holding

* the pair's MLPs as one pack (:func:`impactnet.models.learned.mlp.pack`): ``single`` first
  (member 0, where the pair has one), then each region's committee, region after region;
* ``regions`` (R + 1,): region r's committee is the members ``regions[r]:regions[r + 1]``
  (none for region 0, ``"none"``);
* the region table (7, 27, 27): the region of a labelled contact, by its type code and its
  canonical features + 1 (-1: a region without a committee; ``"none"`` -> 0);
* the constants :data:`~impactnet.models.learned.kernel_pair.CONSTS` (L, e, the depth domain,
  the ``auto`` thresholds).
"""
from __future__ import annotations

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.bundle.manifest import SERVE_EXACT_ONLY
from impactnet.models.geometry import box_features as bf
from impactnet.models.learned.bundle_loader import Bundle
from impactnet.models.learned.bundle_pairs import AutoThresholds, PairModels
from impactnet.models.learned.canonical import parse_region_key
from impactnet.models.learned.kernel_pair import CONSTS
from impactnet.models.learned.mlp import frozen, pack

#: Depth margin (fraction of the pair's shortest edge e) beyond the trained depth range under
#: which a predicted depth still counts as in the domain, for pairs whose bundle entry has no
#: ``auto`` block (which would calibrate it): 0.2 % of e, a fifth of the default scene's range.
DEFAULT_DEPTH_MARGIN = 0.002
#: Number of contact type codes (impactnet.models.contacts), the first axis of the region table.
_N_CODES = len(ct.CONTACT_TYPES)


def program(mlps, regions: np.ndarray, region_table: np.ndarray,
            consts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(values, index)`` of a pair (module docstring; the layout of
    :func:`impactnet.models.learned.kernel_pair.unpack`), read-only."""
    packed = pack(mlps)
    values = np.concatenate([consts, packed.weights])
    header = [len(packed.layers), len(packed.members), len(regions)]
    index = np.concatenate([np.array(header, np.int64), packed.layers.reshape(-1),
                            packed.members, regions, region_table.reshape(-1)]).astype(np.int64)
    return frozen(values), frozen(index)


def _region_table(regions: tuple[str, ...]) -> np.ndarray:
    """(7, 27, 27) int16: (type code, canonical feature_a + 1, canonical feature_b + 1) ->
    region index, -1 for a region without a committee; "none" (code 0, features -1) -> 0."""
    table = np.full((_N_CODES, bf.N_FEATURES + 1, bf.N_FEATURES + 1), -1, np.int16)
    for r, (c, a, b) in enumerate(parse_region_key(key) for key in regions):
        table[c, a + 1, b + 1] = r
    table[ct.NONE, 0, 0] = 0
    return frozen(table)


class PairRuntime:
    """A pair's models and constants (see the module docstring)."""

    def __init__(self, models: PairModels, bundle: Bundle):
        half_a, half_b = np.array(models.size_a) / 2, np.array(models.size_b) / 2
        self.key = models.key
        self.size_a, self.size_b = models.size_a, models.size_b
        self.scale = float(half_a.max() + half_b.max())  # L, metres
        self.edge = float(2.0 * min(half_a.min(), half_b.min()))  # e, metres
        self.auto: AutoThresholds | None = models.auto
        self.exact_only = models.serve == SERVE_EXACT_ONLY  # every mode answers exactly
        margin = models.auto.depth_margin if models.auto else DEFAULT_DEPTH_MARGIN
        self.depth_lo = models.depth_fraction[0] - margin  # fractions of e
        self.depth_hi = models.depth_fraction[1] + margin
        self.single = bundle.mlps[models.single] if models.single else None
        self.labeller = models.labeller
        self.regions = models.regions
        self.region_table = _region_table(models.regions)
        committees = [[bundle.mlps[m] for m in models.experts[r]] for r in models.regions[1:]]
        first = int(self.single is not None)
        bounds = np.cumsum([first, 0] + [len(c) for c in committees])
        self.program = program([self.single] * first + [m for c in committees for m in c],
                               bounds.astype(np.int64), self.region_table, self._consts())

    def _consts(self) -> np.ndarray:
        """The pair's constants in the kernel's order (:data:`CONSTS`)."""
        auto = self.auto
        values = {"scale": self.scale, "edge": self.edge, "depth_lo": self.depth_lo,
                  "depth_hi": self.depth_hi,
                  "confidence_min": auto.confidence_min if auto else np.nan,
                  "normal_spread_max": auto.normal_spread_max_deg if auto else np.nan,
                  "point_spread_max": auto.point_spread_max * self.edge if auto else np.nan}
        return np.array([values[name] for name in CONSTS], np.float64)

    def supports(self, mode: str) -> bool:
        """Whether this pair has the models of ``mode`` (auto needs its thresholds too); an
        exact-only pair supports every mode (the exact solver answers)."""
        if self.exact_only:
            return True
        if mode == "single":
            return self.single is not None
        if mode == "committee":
            return self.labeller is not None
        return self.labeller is not None and self.auto is not None
