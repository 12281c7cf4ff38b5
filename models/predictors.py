"""One entry point for every predictor: :func:`load_predictor`.

``load_predictor(name, bundle=None)`` returns a callable with
:func:`impactnet.models.box.exact.box_box`'s signature that returns `Contacts` with ``confidence``
and ``predictor`` filled. Names: ``exact`` (the SAT solver, no bundle needed), ``single``,
``committee``, ``auto`` (learned, from a bundle: a folder path or a loaded
:class:`impactnet.models.learned.bundle_loader.Bundle`; None = the shipped default bundle,
:data:`DEFAULT_BUNDLE`). A folder may be a plain bundle or a bundle store, which reads its
``current`` version (:func:`impactnet.models.bundle.store.resolve_bundle`).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from impactnet.models.box.exact import box_box
from impactnet.models.bundle.store import resolve_bundle
from impactnet.models.contacts import Contacts
from impactnet.models.learned.batch import CommitteePredictor, Prediction, SinglePredictor
from impactnet.models.learned.bundle_loader import Bundle, BundleError, read_bundle
from impactnet.models.learned.chain import FallbackChain
from impactnet.models.learned.pair_dispatch import UnsupportedPairError

#: The bundle of the default scene, shipped in the repository.
DEFAULT_BUNDLE = Path(__file__).resolve().parent / "bundles" / "quay_crane"
PREDICTOR_NAMES = ("exact", "single", "committee", "auto")
#: How each learned name is built from a bundle: ``auto`` is a chain, the committee first and
#: the exact solver for what it declines.
_LEARNED = {"single": SinglePredictor, "committee": CommitteePredictor,
            "auto": lambda bundle: FallbackChain(CommitteePredictor(bundle))}

__all__ = ["DEFAULT_BUNDLE", "PREDICTOR_NAMES", "BundleError", "ExactPredictor", "Prediction",
           "UnsupportedPairError", "load_predictor"]


class ExactPredictor:
    """The exact solver behind the predictor interface (confidence 1, predictor "exact")."""

    mode = "exact"
    version = "exact"

    def __call__(self, size_a, position_a, quaternion_a, size_b, position_b,
                 quaternion_b) -> Contacts:
        return box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)

    def predict(self, size_a, position_a, quaternion_a, size_b, position_b,
                quaternion_b) -> Prediction:
        """As calling it, with the (zero) spreads of the learned predictors' ``predict``."""
        contacts = box_box(size_a, position_a, quaternion_a, size_b, position_b, quaternion_b)
        return Prediction(contacts, np.zeros(len(contacts)), np.zeros(len(contacts)))

    def __repr__(self) -> str:
        return "<exact predictor>"


def load_predictor(name: str = "auto", bundle: str | os.PathLike | Bundle | None = None,
                   strict: bool = True):
    """The predictor ``name`` (see the module docstring).

    ``strict=False`` gives a learned predictor even where the bundle has no model of that mode
    for any box pair (a bundle of compound pairs: every box pair is then unsupported, 422).

    Raises
    ------
    ValueError
        Unknown name.
    impactnet.models.bundle.manifest.BundleError
        The bundle is missing, altered or malformed (a learned name without a bundle and no
        shipped default is reported the same way, naming the folder looked at).
    """
    if name not in PREDICTOR_NAMES:
        raise ValueError(f"unknown predictor {name!r}; choose one of {PREDICTOR_NAMES}")
    if name == "exact":
        return ExactPredictor()
    if bundle is None:
        if not DEFAULT_BUNDLE.is_dir():
            raise BundleError(f"predictor {name!r} needs a trained bundle and none was given; "
                              f"the default bundle {DEFAULT_BUNDLE} does not exist (build it "
                              "with `impactnet train`, or use predictor 'exact')")
        bundle = DEFAULT_BUNDLE
    if not isinstance(bundle, Bundle):
        bundle = read_bundle(resolve_bundle(bundle))  # a store reads its current version
    predictor = _LEARNED[name](bundle)
    if strict and not any(pair.supports(name) for pair in predictor.pairs) and name != "auto":
        raise BundleError(f"bundle {bundle.version} has no {name!r} models for any pair")
    return predictor
