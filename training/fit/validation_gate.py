"""The validation gate: may a newly trained bundle become a store's ``current`` version?

The gate judges what the bundle **serves**. Each pair's recorded decision
(:mod:`impactnet.training.jobs.decisions`, taken before the gate) says whether its learned path or
the exact solver answers it: a pair whose learned path is too slow *or misses the scene's tolerance*
is decided exact-only there (:func:`impactnet.training.bench.learned.decide.serve_decision`).
:func:`validation_gate` checks a bundle manifest against its scene. It passes when

1. the manifest was built for this scene (name and hash) and covers every pair of the scene;
2. on every **learned** pair's **held-out test split** (rows nothing was fitted or calibrated
   on), the ``auto`` mode — the one the service serves by default: committee answers, the
   exact solver where the calibrated thresholds say unsure — meets the scene's accuracy
   (``[accuracy]`` of the scene file, :class:`impactnet.models.scenes.Accuracy`):
   99th percentile of the normal angle error <= ``accuracy.normal_deg`` degrees and 99th
   percentile of the point error <= ``accuracy.point_fraction`` of the pair's shortest edge
   (rows handed to the exact solver count with error 0, as in ``impactnet.training.fit.pair``);
3. on every learned pair, the share of test rows ``auto`` hands to the exact solver is at most
   :attr:`GateConfig.max_fallback_share` (default 1.0, i.e. no bound: falling back is slow,
   never wrong; bound it to refuse a bundle that would mostly not be used).

4. the same accuracy bounds hold for the **served** predictor on **every** pair
   (:func:`served_checks`): the bundle's ``auto`` as ``models.load_predictor`` runs it (its
   decisions honoured: an exact-only pair answered by the exact solver; float32 features, the
   exact labeller, the dispatch), on :attr:`GateConfig.served_rows` fresh rows per pair from a
   stream no training or evaluation run draws from, against the exact solver, with no contact
   flag differing from the exact solver's (the fallback-share bound: learned pairs only). The
   training-side figures above come from the same networks on the training code's features;
   this check catches what only the serving path could get wrong.

An exact-only pair's learned-path figures (checks 2-3, and its fallback share in check 4) are
still listed, marked ``informative`` (its learned path is not served, so they cannot fail the
gate); its served answers are held to check 4's accuracy and contact flags like every pair's.
A manifest without decisions (built before them) serves every pair learned. The same checks
are listed for the pooled test figures of all pairs (``figures.test``), for the record; the
verdict is per pair, since every pair is served on its own.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from impactnet.models.bundle.format import SERVE_LEARNED, decision_of
from impactnet.models.scenes import Scene

#: Stream of the served check's rows under each pair's seed (training draws from chunk
#: indices, 1_000_001 and 2_000_00x; ``impactnet evaluate`` from 3_000_001).
SERVED_STREAM = 5_000_001

#: The percentile of ``auto``'s test errors that the scene's tolerance bounds.
GATE_PERCENTILE = "p99"


@dataclass(frozen=True)
class GateConfig:
    """Bounds of :func:`validation_gate` (None: the scene's own)."""

    normal_deg: float | None = None  # bound on auto's p99 normal error, degrees
    point_fraction: float | None = None  # bound on auto's p99 point error, fraction of edge
    max_fallback_share: float = 1.0  # largest share of test rows auto may give to exact
    served_rows: int = 5000  # fresh rows per pair for the served check (0: skip it)


@dataclass
class GateResult:
    """The verdict of :func:`validation_gate`."""

    passed: bool  # every check passed
    checks: list[dict] = field(default_factory=list)  # {"what", "value", "bound", "met"}

    @classmethod
    def of(cls, checks: list[dict]) -> GateResult:
        """The verdict of ``checks``: passed where every check not marked informative is
        met."""
        return cls(all(c["met"] for c in checks if not c.get("informative")), list(checks))

    @property
    def failures(self) -> list[str]:
        """One line per failed check."""
        return [_line(c) for c in self.checks if not c["met"] and not c.get("informative")]

    def to_dict(self) -> dict:
        """JSON-ready form (stored in the manifest as ``validation_gate``)."""
        return {"passed": self.passed, "checks": self.checks}


def _line(check: dict) -> str:
    value = "not measured" if check["value"] is None else f"{check['value']:.6g}"
    bound = "" if check["bound"] is None else f" (bound {check['bound']:.6g})"
    return f"{check['what']}: {value}{bound}"


def _check(what: str, value, bound: float) -> dict:
    met = value is not None and value <= bound
    return {"what": what, "value": value, "bound": bound, "met": bool(met)}


def _auto_checks(where: str, auto: dict, bounds: tuple[float, float, float]) -> list[dict]:
    normal, point, fallback = bounds
    return [_check(f"{where} auto {GATE_PERCENTILE} normal (deg)",
                   auto["normal_deg"][GATE_PERCENTILE], normal),
            _check(f"{where} auto {GATE_PERCENTILE} point (fraction of edge)",
                   auto["point_fraction"][GATE_PERCENTILE], point),
            _check(f"{where} auto fallback share", auto["fallback_share"], fallback)]


def _bounds(scene: Scene, config: GateConfig) -> tuple[float, float, float]:
    return (scene.accuracy.normal_deg if config.normal_deg is None else config.normal_deg,
            (scene.accuracy.point_fraction if config.point_fraction is None
             else config.point_fraction),
            config.max_fallback_share)


def serves_learned(block: dict, key: str) -> bool:
    """Whether a pair's manifest entry ``block`` is served by its learned models (its recorded
    ``decision``; none recorded: learned)."""
    return decision_of(block.get("decision"), f"pairs[{key!r}]")[0] == SERVE_LEARNED


def _not_served(checks: list[dict]) -> list[dict]:
    """``checks`` of a learned path the bundle does not serve: listed, marked informative."""
    return [dict(c, what=f"{c['what']} (learned path not served: exact-only)",
                 informative=True) for c in checks]


def served_figures(auto, manifest: dict, scene: Scene, index: int, rows: int) -> dict:
    """``auto``'s figures on ``rows`` fresh rows of pair ``index`` (the stream
    :data:`SERVED_STREAM` under the manifest's data seed) against the exact solver: p99 errors
    and fallback share as in a manifest's ``test.auto``, and ``flags_differing``, the rows
    whose contact flag differs from the exact solver's.

    ``auto`` is a predictor of ``models.load_predictor``: the bundle as served (check 4), or
    its learned path with the decisions not yet taken (what the decision weighs).
    """
    from impactnet.training.evaluate.data import INPUTS, datagen_config, held_out_rows
    from impactnet.training.evaluate.metrics import row_record

    seed = int((manifest.get("seeds") or {}).get("data", 0))
    data = held_out_rows(scene, index, rows, seed, datagen_config(manifest), SERVED_STREAM)
    record = row_record(auto(*(data[k] for k in INPUTS)), data, "auto")
    both = record.both
    return {"normal_deg": {GATE_PERCENTILE: _p99(record.normal_deg[both])},
            "point_fraction": {GATE_PERCENTILE: _p99(record.point_pct[both] / 100.0)},
            "fallback_share": float(record.fallback.mean()),
            "flags_differing": int((record.colliding != record.predicted).sum())}


def served_checks(manifest: dict, tensors: dict, scene: Scene,
                  config: GateConfig | None = None) -> list[dict]:
    """Check 4 of the module docstring: the served ``auto`` of the candidate bundle
    (``manifest`` with its decisions, and ``tensors``, not yet written) on fresh rows of every
    pair (:func:`served_figures`)."""
    from impactnet.models import load_predictor
    from impactnet.models.learned.bundle_loader import bundle_in_memory

    config = config or GateConfig()
    if config.served_rows <= 0:
        return []
    auto = load_predictor("auto", bundle_in_memory(manifest, tensors))
    checks = []
    for index, pair in enumerate(scene.pairs):
        figures = served_figures(auto, manifest, scene, index, config.served_rows)
        served = _auto_checks(f"{pair.key} served", figures, _bounds(scene, config))
        if not serves_learned(manifest["pairs"][pair.key], pair.key):
            served[-1:] = _not_served(served[-1:])  # no learned path to fall back from
        checks += served
        checks.append(_check(f"{pair.key} served contact flags differing from exact",
                             figures["flags_differing"], 0))
    return checks


def _p99(values) -> float | None:
    import numpy as np

    return float(np.percentile(values, 99)) if len(values) else None


def validation_gate(manifest: dict, scene: Scene, config: GateConfig | None = None) -> GateResult:
    """Check a bundle manifest against ``scene`` (see the module docstring).

    Parameters
    ----------
    manifest : dict
        The bundle's manifest (``scene``, ``pairs[key]["test"]["auto"]``, each pair's
        ``decision`` where recorded, ``figures``).
    scene : impactnet.models.scenes.Scene
        The scene the bundle is for; its ``accuracy`` gives the default bounds.
    config : GateConfig, optional
        Other bounds.
    """
    config = config or GateConfig()
    bounds = _bounds(scene, config)
    built_for = manifest.get("scene") or {}
    checks = [{"what": "scene name and hash", "value": None, "bound": None,
               "met": built_for == {"name": scene.name, "hash": scene.hash()}}]
    pairs = manifest.get("pairs") or {}
    for pair in scene.pairs:
        block = pairs.get(pair.key)
        if block is None:
            checks.append({"what": f"{pair.key} trained", "value": None, "bound": None,
                           "met": False})
            continue
        learned = _auto_checks(pair.key, block["test"]["auto"], bounds)
        checks += learned if serves_learned(block, pair.key) else _not_served(learned)
    pooled = (manifest.get("figures") or {}).get("test")
    if pooled is not None:  # for the record only (see the module docstring)
        checks += [dict(c, informative=True) for c in _auto_checks("pooled", pooled["auto"],
                                                                     bounds)]
    return GateResult.of(checks)
