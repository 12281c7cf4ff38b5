"""The validation gate: may a newly trained bundle become a store's ``current`` version?

:func:`validation_gate` checks a bundle manifest against its scene. It passes when

1. the manifest was built for this scene (name and hash) and covers every pair of the scene;
2. on every pair's **held-out test split** (rows nothing was fitted or calibrated on), the
   ``auto`` mode — the one the service serves by default: committee answers, the exact solver
   where the calibrated thresholds say unsure — meets the scene's accuracy
   (``[accuracy]`` of the scene file, :class:`models.scenes.Accuracy`):
   99th percentile of the normal angle error <= ``accuracy.normal_deg`` degrees and 99th
   percentile of the point error <= ``accuracy.point_fraction`` of the pair's shortest edge
   (rows handed to the exact solver count with error 0, as in ``training.train_pair``);
3. on every pair, the share of test rows ``auto`` hands to the exact solver is at most
   :attr:`GateConfig.max_fallback_share` (default 1.0, i.e. no bound: falling back is slow,
   never wrong; bound it to refuse a bundle that would mostly not be used).

The same checks are listed for the pooled test figures of all pairs (``figures.test``), for
the record; the verdict is per pair, since every pair is served on its own.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from models.scenes import Scene

#: The percentile of ``auto``'s test errors that the scene's tolerance bounds.
GATE_PERCENTILE = "p99"


@dataclass(frozen=True)
class GateConfig:
    """Bounds of :func:`validation_gate` (None: the scene's own)."""

    normal_deg: float | None = None  # bound on auto's p99 normal error, degrees
    point_fraction: float | None = None  # bound on auto's p99 point error, fraction of edge
    max_fallback_share: float = 1.0  # largest share of test rows auto may give to exact


@dataclass
class GateResult:
    """The verdict of :func:`validation_gate`."""

    passed: bool  # every check passed
    checks: list[dict] = field(default_factory=list)  # {"what", "value", "bound", "met"}

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


def validation_gate(manifest: dict, scene: Scene, config: GateConfig | None = None) -> GateResult:
    """Check a bundle manifest against ``scene`` (see the module docstring).

    Parameters
    ----------
    manifest : dict
        The bundle's manifest (``scene``, ``pairs[key]["test"]["auto"]``, ``figures``).
    scene : models.scenes.Scene
        The scene the bundle is for; its ``accuracy`` gives the default bounds.
    config : GateConfig, optional
        Other bounds.
    """
    config = config or GateConfig()
    bounds = (scene.accuracy.normal_deg if config.normal_deg is None else config.normal_deg,
              (scene.accuracy.point_fraction if config.point_fraction is None
               else config.point_fraction),
              config.max_fallback_share)
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
        checks += _auto_checks(pair.key, block["test"]["auto"], bounds)
    verdict = all(c["met"] for c in checks)
    pooled = (manifest.get("figures") or {}).get("test")
    if pooled is not None:  # for the record only (see the module docstring)
        checks += [dict(c, informative=True) for c in _auto_checks("pooled", pooled["auto"],
                                                                     bounds)]
    return GateResult(verdict, checks)
