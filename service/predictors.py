"""Predictors by mode, and the immutable serving state that a request reads once.

Modes: ``exact`` (the SAT solver, always there), ``single``, ``committee``, ``auto`` (learned, from
a bundle): the predictors of :func:`impactnet.models.load_predictor`, called directly with
:func:`pair_args`; :mod:`impactnet.service.state` builds them). A mode that cannot answer raises
:class:`impactnet.service.errors.ModeUnavailable` (409: nothing serves it); a strict learned mode on
a pair its bundle does not cover raises
:class:`impactnet.models.learned.pair_dispatch.UnsupportedPairError` (422 ``unsupported_pair``, see
:mod:`impactnet.service.solve`). Never a 500 and never a silent substitute.

Atomic swaps: a request takes ``app.state.serving`` once
(:func:`impactnet.service.api.deps.get_serving`) and uses that :class:`ServingState` to the end, so
an admin reload that builds a new state beside the old one and replaces the reference never mixes
two model versions in one answer.
"""
from __future__ import annotations

import gc
import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from impactnet import __version__
from impactnet.models.dispatch import Dispatcher
from impactnet.models.learned.pair_dispatch import UnsupportedPairError
from impactnet.models.predictors import PREDICTOR_NAMES
from impactnet.service.errors import ModeUnavailable
from impactnet.service.scene import SceneView

#: The learned modes (every mode the API knows is models.predictors.PREDICTOR_NAMES; which of
#: them this server can serve is in ServingState).
LEARNED_MODES = tuple(m for m in PREDICTOR_NAMES if m != "exact")
NO_BUNDLE_REASON = ("no learned bundle is loaded (start the server with --bundle PATH, or "
                    "ship models/bundles/<scene>); use mode 'exact'")


def pair_args(columns: tuple) -> tuple:
    """The six argument arrays of a predictor call (``box_box``'s signature): the rows
    themselves for one pair, so that the predictors take their N = 1 path."""
    return tuple(a[0] for a in columns) if len(columns[0]) == 1 else tuple(columns)


@dataclass(frozen=True)
class ServingState:
    """Everything a request needs, fixed for the state's lifetime."""

    scene: SceneView  # bodies a request may name
    # mode -> predictor (impactnet.models.load_predictor's; .mode names it), modes that answer
    predictors: dict
    unavailable: dict[str, str]  # mode -> why it cannot answer
    model_version: str  # the bundle's version, or the exact solver's; in every response
    default_mode: str = "exact"  # mode of requests that name none; always one it serves
    bundle: dict | None = None  # description of the learned bundle (GET /v1/models) or None
    compound: dict = field(default_factory=dict)  # "a/b" -> CompoundChain of the compound
    # pairs the bundle serves learned (issue #21); the others are answered by the oracle
    loaded_at: float = field(default_factory=time.time)  # UNIX seconds

    @cached_property
    def dispatcher(self) -> Dispatcher:
        """The one dispatcher of this state's predictors and chains (built once)."""
        learned = {m: p for m, p in self.predictors.items() if m != "exact"}
        return Dispatcher(learned, self.compound)

    def predictor(self, mode: str):
        """The predictor of ``mode``; raises ModeUnavailable (409) naming the reason."""
        found = self.predictors.get(mode)
        if found is None:
            raise ModeUnavailable(mode, self.unavailable.get(mode, "unknown mode"))
        return found

    @property
    def modes(self) -> list[str]:
        return [m for m in PREDICTOR_NAMES if m in self.predictors]

    @property
    def bundle_path(self) -> str | None:
        return self.bundle["path"] if self.bundle else None


def exact_model_version(scene: SceneView) -> str:
    """``exact-<impactnet version>``, plus ``+scene.<hash[:12]>`` when a scene is loaded (its
    sizes decide what an ``object`` name means)."""
    version = f"exact-{__version__}"
    return f"{version}+{scene.name}.{scene.hash[:12]}" if scene.hash else version


def warm_up(state: ServingState) -> None:
    """One call of every predictor on the paper's cube pair (first-call costs, imports); a
    learned mode that has no model for the cubes is skipped (the smoke test covered it)."""
    one = tuple(np.array([v], dtype=np.float64) for v in (
        [2.0, 2.0, 2.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0],
        [2.0, 2.0, 2.0], [0.5, 0.3, 1.95], [1.0, 0.0, 0.0, 0.0]))
    two = tuple(np.repeat(a, 2, axis=0) for a in one)
    for predictor in state.predictors.values():
        for columns in (one, two):
            try:
                result = predictor(*pair_args(columns))
            except UnsupportedPairError:
                break
            if predictor.mode == "exact" and not bool(result.colliding[0]):
                raise RuntimeError("warm-up: the exact solver misses a contact")
    warm_up_compound()


def settle_heap(settings) -> None:
    """Where ``settings.freeze_heap`` says so: collect, then exempt every object alive now
    (the libraries, the scene, the models) from the cyclic garbage collector's later passes
    (``gc.freeze``), before ready.

    A full pass walks every tracked object while it holds the GIL: with numba, SciPy and
    the models loaded that took ~70 ms, and serving large JSON answers (millions of small
    lists) starts one every second or so: /healthz stalled 80-120 ms at each (p99 78-94 ms
    under ``tests/service/hostile/test_memory.py``'s sixteen manifold batches; 6.5-11 ms
    frozen). A reload unfreezes first, so that the old state can be collected.
    """
    if not settings.freeze_heap:
        return
    gc.unfreeze()
    gc.collect()
    gc.freeze()


def warm_up_compound() -> None:
    """The compound paths' first-call costs, paid before ready: SciPy's hull, trimesh and
    the oracle on a box against a small convex part (an inline request imports nothing)."""
    import trimesh  # noqa: F401 - imported for its first-call cost (inline meshes)

    from impactnet.models.compound import compound_answer
    from impactnet.models.compound.body_table import TransientParts
    from impactnet.models.compound.parts import BoxPart, ConvexPart
    from impactnet.models.compound.shapes import frustum_points

    cone = TransientParts((ConvexPart("cone", tuple(map(tuple, frustum_points(0.5, 8, 0.3)))),))
    box = TransientParts((BoxPart("box", (1.0, 1.0, 1.0)),))
    answer = compound_answer(cone, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], box,
                             [0.0, 0.0, 0.79], [1.0, 0.0, 0.0, 0.0])
    if not bool(answer.summary.colliding[0]):
        raise RuntimeError("warm-up: the compound oracle misses a contact")
