"""Predictors by mode, and the immutable serving state that a request reads once.

Modes: ``exact`` (the SAT solver, always there), ``single``, ``committee``, ``auto`` (learned,
from a bundle; they arrive with the learned-predictor issue). A mode that cannot answer raises
:class:`service.errors.ModeUnavailable` (409 when nothing serves it, 422 when the bundle does
not cover the requested pair), never a 500 and never a silent substitute.

Atomic swaps: a request takes ``app.state.serving`` once (:func:`service.deps.serving`) and
uses that :class:`ServingState` to the end, so a later admin reload that builds a new state
beside the old one and replaces the reference never mixes two model versions in one answer.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from impactnet import __version__
from models.contacts import Contacts
from models.exact import box_box
from service.errors import ModeUnavailable
from service.scene import EMPTY_SCENE, ScenesUnavailable, SceneView, load_scene_view

#: Every mode the API knows; which of them this server can serve is in ServingState.
KNOWN_MODES = ("exact", "single", "committee", "auto")
LEARNED_MODES = ("single", "committee", "auto")
NO_BUNDLE_REASON = ("no learned bundle is loaded; the learned predictors (single, committee, "
                    "auto) are not served yet. Use mode 'exact'.")


@dataclass(frozen=True)
class PairInputs:
    """Validated, broadcast inputs of N pairs (float64, world frame, metres)."""

    size_a: np.ndarray  # (n, 3) full edge lengths, > 0
    position_a: np.ndarray  # (n, 3)
    quaternion_a: np.ndarray  # (n, 4) unit [w, x, y, z]
    size_b: np.ndarray
    position_b: np.ndarray
    quaternion_b: np.ndarray
    object_a: np.ndarray  # (n,) int index into SceneView.object_names, -1 for a raw size
    object_b: np.ndarray

    def __len__(self) -> int:
        return int(self.position_a.shape[0])


class Predictor(Protocol):
    """What a mode's predictor offers: N pairs in, N contacts out (batch of 1 is a batch)."""

    name: str  # e.g. "exact"; Contacts.predictor names who answered each row

    def predict(self, pairs: PairInputs) -> Contacts: ...


class ExactPredictor:
    """The exact solver; it covers every pair, named or raw."""

    name = "exact"

    def predict(self, pairs: PairInputs) -> Contacts:
        if len(pairs) == 1:  # plain-float fast path of models.exact
            return box_box(pairs.size_a[0], pairs.position_a[0], pairs.quaternion_a[0],
                           pairs.size_b[0], pairs.position_b[0], pairs.quaternion_b[0])
        return box_box(pairs.size_a, pairs.position_a, pairs.quaternion_a, pairs.size_b,
                       pairs.position_b, pairs.quaternion_b)


@dataclass(frozen=True)
class ServingState:
    """Everything a request needs, fixed for the state's lifetime."""

    scene: SceneView  # bodies a request may name
    predictors: dict[str, Predictor]  # mode -> predictor, for the modes that can answer
    unavailable: dict[str, str]  # mode -> why it cannot answer
    model_version: str  # one string naming the solver / bundle version; in every response
    bundle: dict | None = None  # manifest of the learned bundle; None while there is none
    scene_note: str | None = None  # why the configured scene is not loaded, if it is not
    loaded_at: float = field(default_factory=time.time)  # UNIX seconds

    def predictor(self, mode: str) -> Predictor:
        """The predictor of ``mode``; raises ModeUnavailable (409) naming the reason."""
        found = self.predictors.get(mode)
        if found is None:
            raise ModeUnavailable(mode, self.unavailable.get(mode, "unknown mode"))
        return found

    @property
    def modes(self) -> list[str]:
        return [m for m in KNOWN_MODES if m in self.predictors]


def exact_model_version(scene: SceneView) -> str:
    """``exact-<impactnet version>``, plus ``+scene.<hash[:12]>`` when a scene is loaded (its
    sizes decide what an ``object`` name means)."""
    version = f"exact-{__version__}"
    return f"{version}+{scene.name}.{scene.hash[:12]}" if scene.hash else version


class BundleNotSupported(RuntimeError):
    """A bundle was configured, but this build serves the exact solver only."""


def build_state(scene_name: str | None, bundle: str | None) -> ServingState:
    """Load the scene (and, later, the bundle) into a new :class:`ServingState`.

    Raises
    ------
    service.scene.SceneLoadError
        The scene cannot be loaded.
    BundleNotSupported
        ``bundle`` is set (learned bundles are not served yet).
    """
    if bundle:
        raise BundleNotSupported(
            f"cannot load bundle {bundle!r}: serving learned bundles arrives with the "
            "learned-predictor issue; this build serves mode 'exact' only")
    note = None
    try:
        scene = load_scene_view(scene_name)
    except ScenesUnavailable as exc:
        scene, note = EMPTY_SCENE, str(exc)
    return ServingState(scene=scene, predictors={"exact": ExactPredictor()},
                        unavailable={m: NO_BUNDLE_REASON for m in LEARNED_MODES},
                        model_version=exact_model_version(scene), scene_note=note)


def warm_up(state: ServingState) -> None:
    """One call of every predictor on the paper's cube pair (first-call costs, imports)."""
    one = PairInputs(*(np.array([v], dtype=np.float64) for v in (
        [2.0, 2.0, 2.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0],
        [2.0, 2.0, 2.0], [0.5, 0.3, 1.95], [1.0, 0.0, 0.0, 0.0])),
        np.array([-1]), np.array([-1]))
    two = PairInputs(*(np.repeat(a, 2, axis=0) for a in (
        one.size_a, one.position_a, one.quaternion_a, one.size_b, one.position_b,
        one.quaternion_b, one.object_a, one.object_b)))
    for predictor in state.predictors.values():
        for pairs in (one, two):
            result = predictor.predict(pairs)
            if not bool(result.colliding[0]):
                raise RuntimeError(f"warm-up: predictor {predictor.name!r} misses a contact")
