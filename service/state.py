"""Building a :class:`ServingState`: the scene, the learned bundle, the smoke test.

A state is built in named steps, so that a failed start or admin reload says which failed
(:class:`LoadError` carries the step):

1. ``scene``: the served scene (:func:`impactnet.service.scene.load_scene_view`); a reload keeps the
   scene of the state it replaces.
2. ``resolve``: the bundle folder: ``settings.bundle`` if set (``"none"`` or ``""``: no
   bundle), else the scene's shipped bundle ``models/bundles/<scene name>`` when that folder
   exists, else no bundle (mode ``exact`` only).
3. ``read``: :func:`impactnet.service.limits.bundle_guard.check_bundle_files` first (regular files
within size
   caps, so that no read can block or run without end), then
   :func:`impactnet.models.bundle.format.read_bundle` verifies the manifest, the file list, every
   file's size and SHA-256, the tensors and the pairs.
4. ``scene_hash``: the manifest's scene hash must equal the served scene's (a bundle trained
   for other bodies, depth range or accuracy is refused, never half-used).
5. ``build``: the learned modes' predictors (:func:`models.load_predictor` with the bundle
   already read); a mode the bundle has no models for is unavailable with the reason. The
   default mode is ``auto`` with a bundle and ``exact`` without, unless configured; it must
   be a served mode.
6. ``smoke``: :func:`impactnet.service.smoke.smoke_test` against the exact solver.

The warm-up (:func:`impactnet.service.predictors.warm_up`) and the install follow in
:class:`impactnet.service.runtime.Runtime`. The state's ``model_version`` is the bundle's
``version`` (manifest) when a bundle is loaded; read from a store, ``bundle["store_version"]`` names
the version folder that ``current`` named when it was read (what a replica that follows the store
compares with the pointer, :mod:`impactnet.service.store_follow`).
"""
from __future__ import annotations

from pathlib import Path

from impactnet.models.bundle.format import BundleError
from impactnet.models.learned.bundle_loader import Bundle, read_bundle
from impactnet.models.learned.pair_dispatch import UNSUPPORTED, PairTable
from impactnet.models.predictors import DEFAULT_BUNDLE, load_predictor
from impactnet.service.compound_models import (
    compound_chains,
    compound_smoke,
    describe_compound,
)
from impactnet.service.limits.bundle_guard import check_bundle_files
from impactnet.service.predictors import (
    LEARNED_MODES,
    NO_BUNDLE_REASON,
    ServingState,
    exact_model_version,
)
from impactnet.service.scene import SceneView, load_scene_view
from impactnet.service.settings import Settings
from impactnet.service.smoke import SmokeTestFailed, smoke_test

#: Where shipped bundles live: ``<BUNDLES_DIR>/<scene name>``.
BUNDLES_DIR = DEFAULT_BUNDLE.parent
#: Values of ``settings.bundle`` that mean "no bundle" (compared lower-cased, stripped).
NO_BUNDLE = ("", "none")


class LoadError(RuntimeError):
    """A state could not be built; ``step`` names the step (module docstring)."""

    def __init__(self, step: str, message: str, path: Path | None = None) -> None:
        super().__init__(message)
        self.step, self.path = step, path


def configured_bundle(setting: str | None, scene: SceneView) -> Path | None:
    """The bundle folder of the configuration (step ``resolve``), None for no bundle.

    The folder may be a plain bundle or a bundle store (:mod:`impactnet.models.bundle.store`), whose
    ``current`` version :func:`read_for_scene` reads.
    """
    if setting is None:
        if not scene.name:
            return None
        shipped = BUNDLES_DIR / scene.name
        return shipped if shipped.is_dir() else None
    if setting.strip().lower() in NO_BUNDLE:
        return None
    return Path(setting).expanduser()


def read_for_scene(path: Path, scene: SceneView) -> Bundle:
    """Steps ``read`` and ``scene_hash``: the verified bundle at ``path``, built for ``scene``."""
    return read_version_for_scene(path, scene)[0]


def read_version_for_scene(path: Path, scene: SceneView) -> tuple[Bundle, str | None]:
    """:func:`read_for_scene`, and the store version read (None for a plain bundle folder).

    A store's pointer is read once: the files checked, the bundle read and the version
    reported are those of one version, even while a publisher moves ``current``.
    """
    try:
        found = path.is_dir()
    except OSError as exc:  # e.g. a name too long for the file system (ENAMETOOLONG)
        raise LoadError("read", f"bundle {str(path)[:200]!r}: {exc.strerror}", path) from exc
    if not found:
        raise LoadError("read", f"bundle {str(path)!r}: no such folder", path)
    try:
        folder = check_bundle_files(path)  # regular files within their caps: no read blocks
        bundle = read_bundle(folder)  # a store reads its current version
    except (BundleError, OSError) as exc:
        raise LoadError("read", f"bundle {str(path)!r} refused: {exc}", path) from exc
    built_for = bundle.manifest.get("scene") or {}
    name, digest = built_for.get("name"), built_for.get("hash")
    if scene.hash is None:
        raise LoadError("scene_hash", f"bundle {str(path)!r} was built for scene {name!r} and "
                        "no scene is served; start the server with that scene", path)
    if digest != scene.hash:
        raise LoadError(
            "scene_hash", f"bundle {str(path)!r} was built for scene {name!r} with hash "
            f"{str(digest)[:12]}, but the served scene {scene.name!r} has hash "
            f"{scene.hash[:12]} (its bodies, pairs, depth range or accuracy differ); retrain "
            "the bundle for this scene, or serve without it (--bundle none)", path)
    return bundle, (folder.name if folder != path else None)


def learned_predictors(bundle: Bundle) -> tuple[dict, dict[str, str]]:
    """Step ``build``: (mode -> predictor, mode -> why it is unavailable)."""
    predictors, unavailable = {}, {}
    for mode in LEARNED_MODES:
        try:  # a bundle of compound pairs serves every mode (issue #21): its box pairs none
            predictors[mode] = load_predictor(mode, bundle, strict=not bundle.compound)
        except BundleError as exc:
            unavailable[mode] = str(exc)
    return predictors, unavailable


#: The figures of a pair's decision that GET /v1/models shows (the manifest has them all).
DECISION_FIGURES = ("speedup_n1", "speedup_batch", "fallback_share", "normal_p99_deg",
                    "point_p99_fraction", "poses")


def describe(bundle: Bundle, path: Path, scene: SceneView) -> dict:
    """The bundle as GET /v1/models shows it: path, version, scene and hash, creation,
    checksums, the pairs it covers with their modes, validation metrics and auto
    thresholds, and which scene pairs it covers (the others are exact-only)."""
    manifest = bundle.manifest
    pairs = {}
    for key, models in bundle.pairs.items():
        entry = manifest["pairs"][key]
        modes = (["single"] if models.single else []) + (
            ["committee", "auto"] if models.labeller else [])
        pairs[key] = {
            "size_a": list(models.size_a), "size_b": list(models.size_b),
            "depth_fraction": list(models.depth_fraction), "modes": modes,
            "regions": len(models.regions),
            "auto": None if models.auto is None else dict(models.auto.__dict__),
            "validation": entry.get("validation", {}),
            "serve": models.serve,  # "exact-only": every mode answers it exactly (issue #21)
            "decision": None if models.decision is None else {
                k: models.decision["figures"].get(k) for k in DECISION_FIGURES},
        }
    table = PairTable([(m.size_a, m.size_b) for m in bundle.pairs.values()])
    covered, missing = [], []
    for a, b in scene.pairs:  # a compound body has no size here: the oracle answers its pairs
        sizes = scene.size_of(a), scene.size_of(b)
        hit = None not in sizes and table.match_one(*sizes) != UNSUPPORTED
        (covered if hit else missing).append(f"{a}/{b}")
    return {
        "compound_pairs": describe_compound(bundle),
        "path": str(path.resolve()),
        "version": bundle.version,
        "scene": manifest.get("scene"),
        "created_utc": manifest.get("created_utc"),
        "impactnet_version": manifest.get("impactnet_version"),
        "format_version": manifest.get("format_version"),
        "rebuild_command": manifest.get("rebuild_command"),
        "files": manifest.get("files"),
        "pairs": pairs,
        "scene_pairs_covered": covered,
        "scene_pairs_not_covered": missing,
    }


def default_mode(setting: str | None, predictors: dict, unavailable: dict) -> str:
    """The configured default mode, or auto with a bundle and exact without; it must be
    served (step ``build``)."""
    mode = setting or ("auto" if "auto" in predictors else "exact")
    if mode not in predictors:
        raise LoadError("build", f"default mode {mode!r} is not served: "
                        f"{unavailable.get(mode, 'unknown mode')}")
    return mode


def _no_report(step: str) -> None:
    """The default ``on_step`` of :func:`state_for`: nobody is told."""


def state_for(scene: SceneView, path: Path | None, settings: Settings,
              on_step=_no_report) -> ServingState:
    """Steps ``read`` to ``smoke`` for ``scene`` and the bundle at ``path`` (None: none);
    ``on_step(name)`` is called as each step begins (a reload reports where it stands)."""
    predictors: dict = {"exact": load_predictor("exact")}
    if path is None:
        unavailable = {m: NO_BUNDLE_REASON for m in LEARNED_MODES}
        mode = default_mode(settings.default_mode, predictors, unavailable)
        return ServingState(scene=scene, predictors=predictors, unavailable=unavailable,
                            model_version=exact_model_version(scene), default_mode=mode)
    on_step("read")
    bundle, store_version = read_version_for_scene(path, scene)
    on_step("build")
    learned, unavailable = learned_predictors(bundle)
    predictors.update(learned)
    mode = default_mode(settings.default_mode, predictors, unavailable)
    on_step("smoke")
    try:
        report = smoke_test(learned, bundle, settings.smoke_poses)
    except SmokeTestFailed as exc:
        raise LoadError("smoke", f"bundle {str(path)!r} failed the smoke test: {exc}",
                        path) from exc
    chains = compound_chains(bundle, scene)
    report["compound_pairs"] = compound_smoke(chains, settings.smoke_poses)
    info = describe(bundle, path, scene) | {"store_version": store_version, "smoke": report}
    return ServingState(scene=scene, predictors=predictors, unavailable=unavailable,
                        model_version=bundle.version, default_mode=mode, bundle=info,
                        compound=chains)


def build_state(settings: Settings) -> ServingState:
    """The state of a starting server (module docstring).

    Raises
    ------
    impactnet.service.scene.SceneLoadError
        The scene cannot be loaded.
    LoadError
        The bundle cannot be served (the step and the reason are in it).
    """
    scene = load_scene_view(settings.scene)
    return state_for(scene, configured_bundle(settings.bundle, scene), settings)
