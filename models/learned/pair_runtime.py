"""One pair's models ready to run: everything a predictor needs, computed once at load time.

:class:`PairRuntime` holds the pair's lengths (``L``, ``e``), its trained depth domain, its
MLPs (the committees stacked for batched matmuls) and the region tables (type, canonical
features and axis of each region with a committee, and :meth:`PairRuntime.region_of`, the
lookup from a labelled contact to its region), plus the committee's kernel
:func:`member_stats` (K member outputs -> mean, spread).
"""
from __future__ import annotations

import math

import numpy as np

from impactnet.models import contacts as ct
from impactnet.models.bundle.format import SERVE_EXACT_ONLY, AutoThresholds, Bundle, PairModels
from impactnet.models.geometry import box_features as bf
from impactnet.models.learned.canonical import parse_region_key
from impactnet.models.learned.mlp import MLPStack

#: Depth margin (fraction of the pair's shortest edge e) beyond the trained depth range under
#: which a predicted depth still counts as in the domain, for pairs whose bundle entry has no
#: ``auto`` block (which would calibrate it): 0.2 % of e, a fifth of the default scene's range.
DEFAULT_DEPTH_MARGIN = 0.002
#: Contact types whose experts ``auto`` never trusts where clipping matters (the labeller's
#: point is not exact): measured on stacking poses (a container set down flat on another with a
#: yaw of 0.5-2 degrees), the face-face experts' point errors reach 30-150 % of the shortest
#: edge while their spread stays small, so no calibrated threshold catches them; ``auto``
#: answers these rows exactly (about 4-9 % of the default scene's first contacts).
AUTO_EXACT_TYPES = (ct.FACE_FACE,)
#: Number of contact type codes (impactnet.models.contacts), the first axis of the region table.
_N_CODES = len(ct.CONTACT_TYPES)
#: Member normals shorter than this (dimensionless) count as the fallback direction in the
#: spread (see impactnet.models.learned.canonical.NORMAL_NORM_MIN).
_NORM_FLOOR = 1e-6


class PairRuntime:
    """A pair's models and constants (see the module docstring)."""

    def __init__(self, models: PairModels, bundle: Bundle):
        half_a, half_b = np.array(models.size_a) / 2, np.array(models.size_b) / 2
        self.key = models.key
        self.size_a, self.size_b = models.size_a, models.size_b
        self.scale = float(half_a.max() + half_b.max())  # L, metres
        self.inv_scale = 1.0 / self.scale
        self.edge = float(2.0 * min(half_a.min(), half_b.min()))  # e, metres
        self.auto: AutoThresholds | None = models.auto
        self.exact_only = models.serve == SERVE_EXACT_ONLY  # every mode answers exactly
        margin = models.auto.depth_margin if models.auto else DEFAULT_DEPTH_MARGIN
        self.depth_lo = models.depth_fraction[0] - margin  # fractions of e
        self.depth_hi = models.depth_fraction[1] + margin
        self.single = bundle.mlps[models.single] if models.single else None
        self.labeller = models.labeller
        self.regions = models.regions
        parsed = [parse_region_key(r) for r in models.regions]
        # (type code, canonical feature_a + 1, canonical feature_b + 1) -> region, -1 for a
        # region without a committee; "none" (code 0, features -1) -> 0.
        self.region_table = np.full((_N_CODES, bf.N_FEATURES + 1, bf.N_FEATURES + 1), -1,
                                    np.int16)
        for r, (c, a, b) in enumerate(parsed):
            self.region_table[c, a + 1, b + 1] = r
        self.region_table[ct.NONE, 0, 0] = 0
        self.region_dict = {(c, a, b): r for r, (c, a, b) in enumerate(parsed)}
        self.experts = [None] + [MLPStack([bundle.mlps[m] for m in models.experts[r]])
                                 for r in models.regions[1:]]
        self._committee_order()
        if self.auto is not None:
            self.spread_normal_max = self.auto.normal_spread_max_deg  # degrees
            self.spread_point_max = self.auto.point_spread_max * self.edge  # metres

    def _committee_order(self) -> None:
        """Regions ranked so that regions with committees of equal size K are neighbours
        ("none" first): ``rank`` (R,) int16 region -> rank, ``by_rank`` (R,) rank -> region,
        ``k_groups``: (K, first rank, end rank) of each run of equal K."""
        sizes = [0] + [stack.k for stack in self.experts[1:]]
        self.by_rank = np.array(sorted(range(len(sizes)), key=lambda r: (r > 0, sizes[r], r)),
                                np.int64)
        self.rank = np.empty(len(sizes), np.int16)
        self.rank[self.by_rank] = np.arange(len(sizes))
        self.k_groups = []
        for position, region in enumerate(self.by_rank[1:].tolist(), start=1):
            if self.k_groups and self.k_groups[-1][0] == sizes[region]:
                self.k_groups[-1][2] = position + 1
            else:
                self.k_groups.append([sizes[region], position, position + 1])

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

    def region_of(self, code, feature_a, feature_b) -> np.ndarray:
        """Region index (m,) int16 of contacts with canonical features, -1 where the region
        has no committee (``code`` (m,) int8, features (m,) int8, -1 for none)."""
        return self.region_table[code, feature_a.astype(np.intp) + 1,
                                 feature_b.astype(np.intp) + 1]

    def in_domain(self, depth_fraction):
        """Whether predicted depths (fractions of e) lie in the trained range +- margin."""
        return (depth_fraction >= self.depth_lo) & (depth_fraction <= self.depth_hi)

    def unsure(self, confidence, normal_spread, point_spread, depth_fraction, colliding):
        """Rows ``auto`` hands to the exact solver (arrays of one group's rows)."""
        a = self.auto
        return ((confidence < a.confidence_min) | (normal_spread > self.spread_normal_max)
                | (point_spread > self.spread_point_max)
                | (colliding & ~self.in_domain(depth_fraction)))


def member_stats(columns: np.ndarray, scale: float, spread: bool = True, out=None):
    """Committee mean and spread of K member outputs given as columns.

    Parameters
    ----------
    columns : ndarray, shape (K, 7, m), float32
        ``contact-v1`` outputs of each member, one row per output.
    scale : float
        The pair's L (metres), to express point distances in metres.
    spread : bool
        Compute the spread (else zeros).
    out : (mean, normal_spread, point_spread) arrays to write into, optional.

    Returns
    -------
    mean : ndarray, shape (7, m), float32
    normal_spread : ndarray, shape (m,), float32
        Largest angle between two members' normals, degrees.
    point_spread : ndarray, shape (m,), float32
        Largest distance between two members' points, metres.
    """
    k, _, m = columns.shape
    if out is None:
        out = np.empty((7, m), np.float32), np.empty(m, np.float32), np.empty(m, np.float32)
    mean, normal_spread, point_spread = out
    np.sum(columns, axis=0, out=mean)
    mean *= np.float32(1.0 / k)
    chord2 = np.zeros(m, np.float32)
    dist2 = np.zeros(m, np.float32)
    if spread and k > 1:
        normals = columns[:, 3:6]
        norm2 = (normals * normals).sum(axis=1)
        unit = normals * (1.0 / np.sqrt(np.maximum(norm2, np.float32(_NORM_FLOOR ** 2))))[:, None]
        for i in range(k):
            for j in range(i + 1, k):
                for values, out in ((unit, chord2), (columns[:, :3], dist2)):
                    d = values[i] - values[j]
                    d *= d
                    np.maximum(out, d.sum(axis=0), out=out)
    half_chord = np.minimum(np.sqrt(chord2) * np.float32(0.5), np.float32(1.0))
    np.multiply(np.arcsin(half_chord), np.float32(2.0 * 180.0 / math.pi), out=normal_spread)
    np.multiply(np.sqrt(dist2), np.float32(scale), out=point_spread)
    return mean, normal_spread, point_spread
