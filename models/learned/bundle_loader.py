"""Learned models from a bundle: the frozen MLPs, the box pairs and the compound pairs built from
the plain data that :mod:`impactnet.models.bundle.format` reads and writes.

:func:`build` checks, after the format's own checks (files, checksums, header, float32): every
declared MLP complete with its declared shapes, no tensor outside the declared MLPs, every box
pair (:func:`impactnet.models.learned.bundle_pairs.pair_models`) and every compound pair
(:func:`impactnet.models.learned.compound.bundle_pairs.compound_pair_models`). Anything else
raises :class:`impactnet.models.bundle.manifest.BundleError`. :func:`read_bundle`,
:func:`write_bundle` and :func:`bundle_in_memory` are the bundle functions every predictor and
trainer calls: the format's, with :func:`build` on top (a bundle whose models do not build is
never written).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from impactnet.models.bundle.format import (
    BundleData,
    BundleError,
    bundle_data,
    read_bundle_data,
    write_bundle_data,
)
from impactnet.models.learned.bundle_pairs import PairModels, pair_models
from impactnet.models.learned.compound.bundle_pairs import (
    CompoundPairModels,
    compound_pair_models,
)
from impactnet.models.learned.mlp import MLP, MLPError, MLPSpec

__all__ = ["Bundle", "BundleError", "build", "bundle_in_memory", "read_bundle", "write_bundle"]


@dataclass(frozen=True)
class Bundle:
    """A verified bundle: its manifest, its MLPs by name and its pairs by key."""

    manifest: dict  # the parsed manifest.json
    mlps: dict[str, MLP]  # every MLP the manifest declares
    pairs: dict[str, PairModels]  # "a/b" -> models
    path: Path | None = None  # the folder it was read from, if any
    compound: dict[str, CompoundPairModels] = field(default_factory=dict)  # "a/b" -> models

    @property
    def version(self) -> str:
        """The manifest's ``version``, ``"unversioned"`` where it has none."""
        return str(self.manifest.get("version", "unversioned"))


def _mlps(specs: dict, tensors: dict[str, np.ndarray]) -> dict[str, MLP]:
    """Name -> MLP of every spec of the manifest's ``mlps``, from ``tensors`` (name -> float32
    array); BundleError for a bad spec, a missing or misshapen tensor, or a tensor that no
    declared MLP owns."""
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
    return mlps


def _compound(key: str, entry, mlps: dict[str, MLP]) -> CompoundPairModels:
    """The verified compound pair ``compound_pairs[key]``; its malformed values are
    BundleErrors naming the pair."""
    try:
        return compound_pair_models(key, entry, mlps)
    except BundleError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise BundleError(f"compound_pairs[{key!r}]: {exc}") from None


def build(data: BundleData) -> Bundle:
    """The models of a bundle's content (module docstring); raises BundleError.

    Parameters
    ----------
    data : BundleData
        A manifest and its tensors as the format reads them (header and dtypes checked).

    Returns
    -------
    Bundle
        Its MLPs, box pairs and compound pairs, with ``data``'s manifest and path.
    """
    manifest = data.manifest
    mlps = _mlps(manifest["mlps"], data.tensors)
    pairs = {key: pair_models(key, entry, mlps) for key, entry in manifest["pairs"].items()}
    compound = {key: _compound(key, entry, mlps)
                for key, entry in manifest.get("compound_pairs", {}).items()}
    return Bundle(manifest, mlps, pairs, data.path, compound)


def read_bundle(path) -> Bundle:
    """Read and verify a bundle folder (:func:`impactnet.models.bundle.format.read_bundle_data`,
    then :func:`build`); raises BundleError."""
    return build(read_bundle_data(path))


def write_bundle(path, manifest: dict, tensors: dict[str, np.ndarray]) -> Path:
    """Write a bundle folder atomically (:func:`impactnet.models.bundle.format.write_bundle_data`),
    refusing content whose models do not build.

    Parameters
    ----------
    path : str or PathLike
        The bundle folder; an existing bundle there is replaced.
    manifest : dict
        The manifest without ``files`` (filled there); ``format`` and ``format_version`` are
        set if missing.
    tensors : dict of str -> ndarray
        The MLP tensors (cast to float32, C order).

    Returns
    -------
    Path
        ``path``. Raises BundleError (nothing written) when the content would not read back.
    """
    return write_bundle_data(path, manifest, tensors, check=build)


def bundle_in_memory(manifest: dict, tensors: dict[str, np.ndarray]) -> Bundle:
    """The bundle that :func:`write_bundle` would write, without writing it (its checks, no
    files): to run a candidate's predictors before deciding where it goes."""
    return build(bundle_data(manifest, tensors))
