"""The box pairs of a bundle (manifest ``pairs["a/b"]``) as verified models: each pair's sizes,
trained depth range, ``single`` MLP, region committees (the exact labeller
:data:`impactnet.models.learned.canonical.REGION_LABELLER`, its regions starting with "none",
one committee per other region), ``auto`` thresholds and serving decision.

Every MLP an entry names must exist, take the canonical pose features and give the outputs its
role needs; anything else raises :class:`impactnet.models.bundle.manifest.BundleError`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from impactnet.models.bundle.manifest import BundleError, decision_of, finite_numbers
from impactnet.models.learned import canonical as cn
from impactnet.models.learned.mlp import MLP

_AUTO_KEYS = ("confidence_min", "normal_spread_max_deg", "point_spread_max", "depth_margin")


@dataclass(frozen=True)
class AutoThresholds:
    """When ``auto`` hands a row to the exact solver (calibrated by training, per pair)."""

    confidence_min: float  # confidence below this -> exact (1 in a region with a committee)
    normal_spread_max_deg: float  # max angle between member normals above this (deg) -> exact
    point_spread_max: float  # max member point distance above this (fraction of e) -> exact
    depth_margin: float  # predicted depth outside the scene's range by more (fraction of e)


@dataclass(frozen=True)
class PairModels:
    """The models of one body pair of a bundle (manifest ``pairs["a/b"]``)."""

    key: str  # "a/b", the scene's order; the normal points from a to b
    size_a: tuple[float, float, float]  # full edge lengths of A, metres
    size_b: tuple[float, float, float]  # full edge lengths of B, metres
    depth_fraction: tuple[float, float]  # trained depth range, fractions of the shortest edge
    single: str | None  # MLP name of the single predictor, or None
    labeller: str | None  # the region classifier (REGION_LABELLER), None: no committee
    regions: tuple[str, ...]  # the regions with a committee; regions[0] == "none"
    experts: dict[str, tuple[str, ...]] = field(default_factory=dict)  # region -> MLP names
    auto: AutoThresholds | None = None  # fallback thresholds of auto, or None
    serve: str = "learned"  # SERVE_LEARNED, or SERVE_EXACT_ONLY: every mode answers exactly
    decision: dict | None = None  # manifest `decision`: how `serve` was chosen, with figures


def check_mlp(name, mlps: dict[str, MLP], what: str, n_out: int | None,
              outputs: str = cn.OUTPUTS_VERSION) -> str:
    """``name`` if it is a declared MLP taking pose-v1 and giving ``n_out`` outputs of the
    version ``outputs``."""
    if not isinstance(name, str) or name not in mlps:
        raise BundleError(f"{what}: no MLP {name!r} in the bundle")
    spec = mlps[name].spec
    if spec.layers[0] != cn.N_POSE_FEATURES or spec.inputs != cn.FEATURES_VERSION:
        raise BundleError(f"{what}: MLP {name!r} must take {cn.FEATURES_VERSION} "
                          f"({cn.N_POSE_FEATURES} inputs)")
    if n_out is not None and spec.layers[-1] != n_out:
        raise BundleError(f"{what}: MLP {name!r} has {spec.layers[-1]} outputs, needs {n_out}")
    if spec.outputs != outputs:
        raise BundleError(f"{what}: MLP {name!r} must give {outputs}")
    return name


def _sizes_and_depth(entry: dict, where: str):
    """(size_a, size_b, depth_fraction) of a pair entry, validated."""
    size_a, size_b = (finite_numbers(entry.get(s), 3, f"{where}.{s}")
                      for s in ("size_a", "size_b"))
    if min(size_a + size_b) <= 0:
        raise BundleError(f"{where}: sizes must be > 0")
    depth = finite_numbers(entry.get("depth_fraction"), 2, f"{where}.depth_fraction")
    if not 0.0 <= depth[0] <= depth[1] < 1.0:
        raise BundleError(f"{where}.depth_fraction: need 0 <= lo <= hi < 1, got {depth}")
    return size_a, size_b, depth


def _auto(auto, where: str) -> AutoThresholds | None:
    """A pair entry's optional ``auto`` block, validated."""
    if auto is None:
        return None
    if not isinstance(auto, dict) or set(auto) != set(_AUTO_KEYS):
        raise BundleError(f"{where}.auto: expected exactly the keys {list(_AUTO_KEYS)}")
    values = finite_numbers([auto[k] for k in _AUTO_KEYS], 4, f"{where}.auto")
    if not 0.0 <= values[0] <= 1.0 or min(values[1:]) < 0.0:
        raise BundleError(f"{where}.auto: confidence_min in [0, 1], the others >= 0")
    return AutoThresholds(*values)


def pair_models(key: str, entry, mlps: dict[str, MLP]) -> PairModels:
    """Validated models of the manifest entry ``pairs[key]`` (module docstring), its MLPs
    looked up in ``mlps`` (name -> MLP)."""
    where = f"pairs[{key!r}]"
    if not isinstance(entry, dict):
        raise BundleError(f"{where}: expected an object")
    if len(key.split("/")) != 2 or not all(key.split("/")):
        raise BundleError(f"{where}: pair keys are 'a/b'")
    size_a, size_b, depth = _sizes_and_depth(entry, where)
    single = entry.get("single")
    if single is not None:
        check_mlp(single, mlps, f"{where}.single", cn.N_CONTACT_OUTPUTS)
    labeller, regions, experts = None, (), {}
    if entry.get("classifier") is not None:
        labeller, regions, experts = _committee(entry, mlps, where)
    auto = _auto(entry.get("auto"), where)
    serve, decision = decision_of(entry.get("decision"), where)
    return PairModels(key, size_a, size_b, depth, single, labeller, regions, experts, auto,
                      serve, decision)


def _regions(block, where: str) -> list:
    """The regions of a pair's ``classifier`` block, validated ("none" first, distinct)."""
    if not isinstance(block, dict) or set(block) != {"labeller", "regions"}:
        raise BundleError(f"{where}.classifier: expected {{'labeller', 'regions'}}")
    if block["labeller"] != cn.REGION_LABELLER:
        raise BundleError(f"{where}.classifier.labeller: {block['labeller']!r} is not "
                          f"{cn.REGION_LABELLER!r}")
    regions = block["regions"]
    if (not isinstance(regions, list) or not regions or regions[0] != cn.NONE_KEY
            or len(set(regions)) != len(regions)):
        raise BundleError(f"{where}.classifier.regions: a list of distinct keys, 'none' first")
    for region in regions:
        try:
            cn.parse_region_key(region)
        except ValueError as exc:
            raise BundleError(f"{where}.classifier.regions: {exc}") from None
    return regions


def _committee(entry: dict, mlps: dict[str, MLP], where: str):
    """(labeller, regions, experts) of a pair entry, validated."""
    regions = _regions(entry["classifier"], where)
    experts = entry.get("experts")
    if not isinstance(experts, dict) or set(experts) != set(regions[1:]):
        raise BundleError(f"{where}.experts: need one committee per region except 'none'")
    out = {}
    for region, names in experts.items():
        if not isinstance(names, list) or not names:
            raise BundleError(f"{where}.experts[{region!r}]: a non-empty list of MLP names")
        out[region] = tuple(check_mlp(m, mlps, f"{where}.experts[{region!r}]",
                                      cn.N_CONTACT_OUTPUTS, cn.EXPERT_OUTPUTS_VERSION)
                            for m in names)
    return cn.REGION_LABELLER, tuple(regions), out
