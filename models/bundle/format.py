"""Bundles: a trained model set on disk (docs/learned_predictors.md, "Bundle folder").

A bundle is a folder holding exactly ``manifest.json`` and the files the manifest lists in
``files`` (``weights.safetensors``). Reading (:func:`read_bundle`) verifies, in this order:
the manifest's format and version, that the folder holds no other file and misses none,
every file's size and SHA-256, the tensors (float32, each belonging to a declared MLP, every
declared MLP complete with the declared shapes) and the pairs (every MLP they name exists,
with the input / output widths its role needs; the region classifier is the exact labeller
:data:`impactnet.models.learned.canonical.REGION_LABELLER`, its regions start with "none" and each
other region
has a committee). Anything else raises :class:`BundleError`. Tensors
are read with ``safetensors.numpy`` from the same bytes that were hashed; nothing is pickled.

Writing (:func:`write_bundle`) checks the same rules first, so an unreadable bundle is never
written, then writes into a temporary sibling folder (``.<name>.tmp-<random>``), fsyncs it,
and renames it into place. An existing bundle is first renamed away (``.<name>.old-<random>``)
and deleted after the new one is in place: a crash before the renames leaves the old bundle
untouched (and a temporary folder to delete); a crash between the two renames leaves the old
bundle complete under its ``.old`` name, never half a bundle at ``path``.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import safetensors.numpy

from impactnet.models.bundle.atomic import fsync_dir, replace_folder, write_file
from impactnet.models.learned import canonical as cn
from impactnet.models.learned.mlp import MLP, MLPError, MLPSpec

FORMAT = "impactnet-bundle"
FORMAT_VERSION = 2  # 2: the region classifier is the exact labeller (no classifier MLP)
MANIFEST = "manifest.json"
WEIGHTS = "weights.safetensors"
_AUTO_KEYS = ("confidence_min", "normal_spread_max_deg", "point_spread_max", "depth_margin")
#: A pair's ``decision.serve``: its learned models answer (the modes as documented), or the
#: exact solver answers it in every mode (issue #21's per-pair decision: the learned path was
#: measured and did not pay).
SERVE_LEARNED, SERVE_EXACT_ONLY = "learned", "exact-only"


class BundleError(ValueError):
    """A bundle that is malformed, incomplete, altered or inconsistent."""


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


@dataclass(frozen=True)
class Bundle:
    """A verified bundle: its manifest, its MLPs by name and its pairs by key."""

    manifest: dict  # the parsed manifest.json
    mlps: dict[str, MLP]  # every MLP the manifest declares
    pairs: dict[str, PairModels]  # "a/b" -> models
    path: Path | None = None  # the folder it was read from, if any
    compound: dict = field(default_factory=dict)  # "a/b" -> CompoundPairModels (issue #21)

    @property
    def version(self) -> str:
        return str(self.manifest.get("version", "unversioned"))


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def finite_numbers(value, count: int, what: str) -> tuple[float, ...]:
    """``value`` as ``count`` finite floats (a list or tuple of numbers, no bools), else
    BundleError naming ``what``."""
    if (not isinstance(value, list | tuple) or len(value) != count
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in value)):
        raise BundleError(f"{what}: expected {count} finite numbers, got {value!r}")
    return tuple(float(v) for v in value)


def _check_mlp(name, mlps: dict[str, MLP], what: str, n_out: int | None,
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


def _pair_models(key: str, entry, mlps: dict[str, MLP]) -> PairModels:
    """Validated models of one pair entry (see the module docstring)."""
    where = f"pairs[{key!r}]"
    if not isinstance(entry, dict):
        raise BundleError(f"{where}: expected an object")
    if len(key.split("/")) != 2 or not all(key.split("/")):
        raise BundleError(f"{where}: pair keys are 'a/b'")
    size_a, size_b = (finite_numbers(entry.get(s), 3, f"{where}.{s}")
                      for s in ("size_a", "size_b"))
    if min(size_a + size_b) <= 0:
        raise BundleError(f"{where}: sizes must be > 0")
    depth = finite_numbers(entry.get("depth_fraction"), 2, f"{where}.depth_fraction")
    if not 0.0 <= depth[0] <= depth[1] < 1.0:
        raise BundleError(f"{where}.depth_fraction: need 0 <= lo <= hi < 1, got {depth}")
    single = entry.get("single")
    if single is not None:
        _check_mlp(single, mlps, f"{where}.single", cn.N_CONTACT_OUTPUTS)
    labeller, regions, experts = None, (), {}
    if entry.get("classifier") is not None:
        labeller, regions, experts = _committee(entry, mlps, where)
    auto = entry.get("auto")
    if auto is not None:
        if not isinstance(auto, dict) or set(auto) != set(_AUTO_KEYS):
            raise BundleError(f"{where}.auto: expected exactly the keys {list(_AUTO_KEYS)}")
        values = finite_numbers([auto[k] for k in _AUTO_KEYS], 4, f"{where}.auto")
        if not 0.0 <= values[0] <= 1.0 or min(values[1:]) < 0.0:
            raise BundleError(f"{where}.auto: confidence_min in [0, 1], the others >= 0")
        auto = AutoThresholds(*values)
    serve, decision = decision_of(entry.get("decision"), where)
    return PairModels(key, size_a, size_b, depth, single, labeller, regions, experts, auto,
                      serve, decision)


def decision_of(block, where: str) -> tuple[str, dict | None]:
    """(serve, the block) of a pair's optional ``decision``: ``{"serve": "learned" |
    "exact-only", "figures": {...}, ...}``; no block: learned."""
    if block is None:
        return SERVE_LEARNED, None
    if not isinstance(block, dict) or not isinstance(block.get("figures"), dict):
        raise BundleError(f"{where}.decision: expected an object with `serve` and `figures`")
    if block.get("serve") not in (SERVE_LEARNED, SERVE_EXACT_ONLY):
        raise BundleError(f"{where}.decision.serve: {SERVE_LEARNED!r} or "
                          f"{SERVE_EXACT_ONLY!r}, got {block.get('serve')!r}")
    return block["serve"], block


def _committee(entry: dict, mlps: dict[str, MLP], where: str):
    """(labeller, regions, experts) of a pair entry, validated."""
    block = entry["classifier"]
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
    experts = entry.get("experts")
    if not isinstance(experts, dict) or set(experts) != set(regions[1:]):
        raise BundleError(f"{where}.experts: need one committee per region except 'none'")
    out = {}
    for region, names in experts.items():
        if not isinstance(names, list) or not names:
            raise BundleError(f"{where}.experts[{region!r}]: a non-empty list of MLP names")
        out[region] = tuple(_check_mlp(m, mlps, f"{where}.experts[{region!r}]",
                                       cn.N_CONTACT_OUTPUTS, cn.EXPERT_OUTPUTS_VERSION)
                            for m in names)
    return cn.REGION_LABELLER, tuple(regions), out


def _assemble(manifest, tensors: dict[str, np.ndarray]) -> tuple[dict, dict, dict]:
    """(mlps, pairs, compound pairs) of a manifest and its tensors; BundleError on any
    inconsistency."""
    if not isinstance(manifest, dict):
        raise BundleError("the manifest must be a JSON object")
    if manifest.get("format") != FORMAT or manifest.get("format_version") != FORMAT_VERSION:
        raise BundleError(f"not an {FORMAT} version {FORMAT_VERSION} manifest (format "
                          f"{manifest.get('format')!r}, version "
                          f"{manifest.get('format_version')!r})")
    specs, pairs = manifest.get("mlps"), manifest.get("pairs")
    compound = manifest.get("compound_pairs", {})
    if (not isinstance(specs, dict) or not isinstance(pairs, dict)
            or not isinstance(compound, dict) or not (pairs or compound)):
        raise BundleError("the manifest needs 'mlps' and a non-empty 'pairs' or "
                          "'compound_pairs' object")
    for key, value in tensors.items():
        if value.dtype != np.float32:
            raise BundleError(f"tensor {key!r} is {value.dtype}, the contract says float32")
    mlps, owned = {}, set()
    for name, entry in specs.items():
        try:
            spec = MLPSpec.from_dict(entry)
            mlps[name] = MLP.from_tensors(name, tensors, spec)
        except MLPError as exc:
            raise BundleError(f"mlps[{name!r}]: {exc}") from None
        owned.update(spec.shapes(name))
    extra = sorted(set(tensors) - owned)
    if extra:
        raise BundleError(f"tensors of no declared MLP: {extra[:5]}")
    return (mlps, {key: _pair_models(key, entry, mlps) for key, entry in pairs.items()},
            {key: _compound_models(key, entry, mlps) for key, entry in compound.items()})


def _compound_models(key: str, entry, mlps: dict):
    """A verified compound pair entry (:mod:`impactnet.models.bundle.compound_format`)."""
    from impactnet.models.bundle.compound_format import compound_pair_models

    try:
        return compound_pair_models(key, entry, mlps)
    except BundleError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise BundleError(f"compound_pairs[{key!r}]: {exc}") from None


def bundle_in_memory(manifest: dict, tensors: dict[str, np.ndarray]) -> Bundle:
    """The bundle that :func:`write_bundle` would write, without writing it (its checks, no
    files): to run a candidate's predictors before deciding where it goes."""
    manifest = json.loads(json.dumps(manifest, allow_nan=False))
    manifest.setdefault("format", FORMAT)
    manifest.setdefault("format_version", FORMAT_VERSION)
    arrays = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in tensors.items()}
    mlps, pairs, compound = _assemble(manifest, arrays)
    return Bundle(manifest, mlps, pairs, compound=compound)


def _parse_json(data: bytes):
    def refuse(constant):
        raise BundleError(f"{MANIFEST}: {constant} is not JSON")
    try:
        return json.loads(data.decode("utf-8"), parse_constant=refuse)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BundleError(f"{MANIFEST}: invalid JSON: {exc}") from None


def read_bundle(path) -> Bundle:
    """Read and verify a bundle folder (see the module docstring); raises BundleError."""
    folder = Path(path)
    if not folder.is_dir():
        raise BundleError(f"{folder}: no such bundle folder")
    present = set(os.listdir(folder))
    if MANIFEST not in present:
        raise BundleError(f"{folder}: no {MANIFEST}")
    manifest = _parse_json((folder / MANIFEST).read_bytes())
    files = manifest.get("files") if isinstance(manifest, dict) else None
    if not isinstance(files, dict) or WEIGHTS not in files:
        raise BundleError(f"{folder}: the manifest must list {WEIGHTS} in 'files'")
    if present != {MANIFEST, *files}:
        raise BundleError(f"{folder}: files do not match the manifest (extra "
                          f"{sorted(present - {MANIFEST, *files})}, missing "
                          f"{sorted({MANIFEST, *files} - present)})")
    contents = {}
    for name, entry in files.items():
        data = (folder / name).read_bytes() if (folder / name).is_file() else None
        if (data is None or not isinstance(entry, dict) or len(data) != entry.get("bytes")
                or _sha256(data) != entry.get("sha256")):
            raise BundleError(f"{folder / name}: size or SHA-256 differs from the manifest")
        contents[name] = data
    try:
        tensors = safetensors.numpy.load(contents[WEIGHTS])
    except Exception as exc:  # the Rust SafetensorError derives from Exception only
        raise BundleError(f"{folder / WEIGHTS}: not a safetensors file: {exc}") from None
    mlps, pairs, compound = _assemble(manifest, tensors)
    return Bundle(manifest, mlps, pairs, folder, compound)


def write_bundle(path, manifest: dict, tensors: dict[str, np.ndarray]) -> Path:
    """Write a bundle folder atomically (see the module docstring).

    Parameters
    ----------
    path : str or PathLike
        The bundle folder; an existing bundle there is replaced.
    manifest : dict
        The manifest without ``files`` (filled here); ``format`` and ``format_version`` are
        set if missing.
    tensors : dict of str -> ndarray
        The MLP tensors (cast to float32, C order).

    Returns
    -------
    Path
        ``path``. Raises BundleError (nothing written) when the content would not read back.
    """
    folder = Path(path)
    arrays = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in tensors.items()}
    data = safetensors.numpy.save(arrays)
    manifest = json.loads(json.dumps(manifest, allow_nan=False))  # a deep, JSON-clean copy
    manifest.setdefault("format", FORMAT)
    manifest.setdefault("format_version", FORMAT_VERSION)
    manifest["files"] = {WEIGHTS: {"sha256": _sha256(data), "bytes": len(data)}}
    _assemble(manifest, safetensors.numpy.load(data))
    text = json.dumps(manifest, indent=2, sort_keys=True, allow_nan=False) + "\n"
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = folder.parent / f".{folder.name}.tmp-{uuid.uuid4().hex[:12]}"
    tmp.mkdir()
    try:
        write_file(tmp / WEIGHTS, data)
        write_file(tmp / MANIFEST, text.encode("utf-8"))
        fsync_dir(tmp)
        replace_folder(tmp, folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    fsync_dir(folder.parent)
    return folder
