"""The manifest of a bundle as plain JSON data: its format tag, the checks of its header and of
its tensors' dtype, and the small value checks every entry uses (finite numbers, a pair's
``decision`` block). Knows no MLP and no predictor: the learned side
(:mod:`impactnet.models.learned.bundle_loader`) turns a checked manifest into models.
"""
from __future__ import annotations

import math

import numpy as np

FORMAT = "impactnet-bundle"
FORMAT_VERSION = 2  # 2: the region classifier is the exact labeller (no classifier MLP)
#: A pair's ``decision.serve``: its learned models answer (the modes as documented), or the
#: exact solver answers it in every mode (issue #21's per-pair decision: the learned path was
#: measured and did not pay).
SERVE_LEARNED, SERVE_EXACT_ONLY = "learned", "exact-only"

__all__ = ["FORMAT", "FORMAT_VERSION", "SERVE_EXACT_ONLY", "SERVE_LEARNED", "BundleError",
           "check_header", "check_tensors", "decision_of", "finite_numbers"]


class BundleError(ValueError):
    """A bundle that is malformed, incomplete, altered or inconsistent."""


def finite_numbers(value, count: int, what: str) -> tuple[float, ...]:
    """``value`` as ``count`` finite floats (a list or tuple of numbers, no bools), else
    BundleError naming ``what``."""
    if (not isinstance(value, list | tuple) or len(value) != count
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       and math.isfinite(v) for v in value)):
        raise BundleError(f"{what}: expected {count} finite numbers, got {value!r}")
    return tuple(float(v) for v in value)


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


def check_header(manifest) -> None:
    """Raise BundleError unless ``manifest`` is a JSON object of this format and version with
    an ``mlps`` object and a non-empty ``pairs`` or ``compound_pairs`` object."""
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


def check_tensors(tensors: dict[str, np.ndarray]) -> None:
    """Raise BundleError unless every tensor is float32 (the contract of the weights file)."""
    for key, value in tensors.items():
        if value.dtype != np.float32:
            raise BundleError(f"tensor {key!r} is {value.dtype}, the contract says float32")
