"""Unchanged pairs taken from a store's current bundle, where the per-pair cache has none.

The per-pair cache (:mod:`impactnet.training.data.pair_cache`) is not committed (too big), so on a
fresh clone a store such as ``models/bundles/quay_crane`` has its bundle but no cache.
:func:`open_current` makes the store's current bundle a second source of reuse: a pair of it is
reused for ``scene.pairs[index]`` trained with ``config`` when

1. the bundle has this code's format (:data:`impactnet.models.bundle.format.FORMAT_VERSION`, which
   :func:`impactnet.models.bundle.format.read_bundle` checks) and was written by this impactnet
   version (manifest ``impactnet_version`` equals ``impactnet.__version__``);
2. it was trained with the same :class:`impactnet.training.fit.pair.PairTrainConfig` (manifest
   ``training.config.pair``, JSON-equal, the seed included);
3. it has the pair (same key ``"a/b"``: the same body names, hence the same seed stream) with
   the same sizes (``size_a``, ``size_b``) and depth range (``depth_fraction``) in its block;
4. its scene had the same depth range and accuracy. The manifest records the scene only by
   hash, so the bundle's scene is rebuilt from its pairs (names and sizes) with the present
   depth range and accuracy, and that hash must equal the recorded one. A scene that had a
   body in no pair never matches: its pairs are retrained, never wrongly reused.

Not detected, unlike the cache (which hashes the training code's source): a change of the
training code that keeps impactnet's version and the bundle format. After such a change, run
``impactnet train --no-reuse`` (or bump the version).

A reused pair's :class:`impactnet.training.fit.pair.PairResult` holds the bundle's tensors of the
pair's networks (bit for bit), their ``mlps`` entries, the pair's block (networks renamed by
:func:`impactnet.training.data.pair_cache.reprefix` where the pair's index moved), ``seconds`` 0 and
the test rows re-evaluated from the seeded data
(:func:`impactnet.training.evaluate.scene_figures.reevaluate_pair`, a few seconds per pair). Reused
pairs are not written to the cache: the cache's key vouches for the training code, which a bundle
cannot.
"""
from __future__ import annotations

import copy
import dataclasses
import json
import re
import sys

import safetensors.numpy

from impactnet.models.bundle.format import WEIGHTS, BundleError
from impactnet.models.bundle.store import current_version, resolve_bundle
from impactnet.models.learned.bundle_loader import Bundle, read_bundle
from impactnet.models.scenes import Body, BodyPair, Scene
from impactnet.training.data.pair_cache import plain, reprefix
from impactnet.training.evaluate.scene_figures import reevaluate_pair
from impactnet.training.fit.pair import PairResult, PairTrainConfig

#: A network name of pair ``n`` of a bundle, ``p<n>_...``
#: (:func:`impactnet.training.data.pair_cache.reprefix`).
_PAIR_PREFIX = re.compile(r"^p(\d+)_")


def _log(message: str) -> None:
    print(f"train: {message}", file=sys.stderr, flush=True)


def _config_json(config: PairTrainConfig):
    """``config`` as the manifest records it (JSON types: lists, None for inf)."""
    return json.loads(json.dumps(plain(config), allow_nan=False))


def _strings(value) -> set[str]:
    """Every string in a JSON value, recursively."""
    if isinstance(value, str):
        return {value}
    if isinstance(value, list | dict):
        items = value.values() if isinstance(value, dict) else value
        return set().union(*(_strings(v) for v in items))
    return set()


def bundle_scene_matches(manifest: dict, scene: Scene) -> bool:
    """True where the bundle's scene had ``scene``'s depth range and accuracy (criterion 4)."""
    sizes, pairs = {}, []
    for key, block in manifest["pairs"].items():
        a, b = key.split("/", 1)
        sizes[a], sizes[b] = tuple(block["size_a"]), tuple(block["size_b"])
        pairs.append(BodyPair(a, b))
    old = dataclasses.replace(scene, name=manifest["scene"]["name"], pairs=tuple(pairs),
                              bodies=tuple(Body(name, size) for name, size in sizes.items()))
    return old.hash() == manifest["scene"]["hash"]


class BundleSource:
    """The pairs of one bundle, served as :class:`impactnet.training.fit.pair.PairResult`.

    Parameters
    ----------
    bundle : impactnet.models.bundle.format.Bundle
        A verified bundle (:func:`impactnet.models.bundle.format.read_bundle`).
    """

    def __init__(self, bundle: Bundle) -> None:
        self.bundle = bundle
        self.manifest = bundle.manifest
        self.tensors = safetensors.numpy.load_file(str(bundle.path / WEIGHTS))
        self._scene_ok: dict[str, bool] = {}  # scene hash -> bundle_scene_matches

    @property
    def label(self) -> str:
        """Where a reused pair comes from, for messages."""
        return f"bundle {self.bundle.version}"

    def incompatible(self, config: PairTrainConfig) -> str | None:
        """Why no pair of the bundle can serve ``config`` (criteria 1 and 2), None if some can."""
        from impactnet import __version__

        written = self.manifest.get("impactnet_version")
        if written != __version__:
            return f"written by impactnet {written}, this is {__version__}"
        recorded = ((self.manifest.get("training") or {}).get("config") or {}).get("pair")
        if recorded != _config_json(config):
            return "trained with another training config (seed, data, networks or optimisation)"
        return None

    def pair_change(self, scene: Scene, index: int) -> str | None:
        """What changed of ``scene.pairs[index]`` since the bundle (criteria 3, 4), None if not."""
        key = scene.pairs[index].key
        block = self.manifest["pairs"].get(key)
        if block is None:
            return "new pair"
        size_a, size_b = (list(map(float, s)) for s in scene.pair_sizes()[index])
        if block.get("size_a") != size_a or block.get("size_b") != size_b:
            return "sizes changed"
        if block.get("depth_fraction") != list(map(float, scene.depth_fraction)):
            return "depth range changed"
        if scene.hash() not in self._scene_ok:
            self._scene_ok[scene.hash()] = bundle_scene_matches(self.manifest, scene)
        if not self._scene_ok[scene.hash()]:
            return "the scene's accuracy or depth range differs from the bundle's"
        return None

    def get(self, scene: Scene, index: int, config: PairTrainConfig) -> PairResult | None:
        """The bundle's result of the pair, renamed for ``index``; None where it is not
        reusable (a changed pair says why on stderr)."""
        if self.incompatible(config) is not None:
            return None
        key = scene.pairs[index].key
        change = self.pair_change(scene, index)
        if change is not None:
            _log(f"{key} not taken from {self.label}: {change}")
            return None
        block = copy.deepcopy(self.manifest["pairs"][key])
        block.pop("decision", None)  # measured again for the new bundle (jobs.decisions)
        names = _strings(block) & set(self.manifest["mlps"])
        trained_as = {int(m.group(1)) for m in map(_PAIR_PREFIX.match, names) if m}
        if len(trained_as) != 1 or not all(map(_PAIR_PREFIX.match, names)):
            _log(f"{key} not taken from {self.label}: its network names are not p<n>_...")
            return None
        tensors = {k: v for k, v in self.tensors.items() if k.rpartition(".")[0] in names}
        mlps = {name: copy.deepcopy(self.manifest["mlps"][name]) for name in sorted(names)}
        rows = reevaluate_pair(scene, index, self.bundle.mlps, block, config)
        return reprefix(PairResult(key, tensors, mlps, block, 0.0, rows), trained_as.pop(),
                        index)


def open_current(store, config: PairTrainConfig) -> BundleSource | None:
    """The current bundle of ``store`` as a source of unchanged pairs.

    None where the store has no current version, or where its bundle cannot serve ``config``
    at all (unreadable, another impactnet version or training config: said on stderr).
    """
    if current_version(store) is None:
        return None
    try:
        source = BundleSource(read_bundle(resolve_bundle(store)))
    except (BundleError, OSError) as exc:
        _log(f"the current bundle of {store} is not reused: {exc}")
        return None
    why = source.incompatible(config)
    if why is not None:
        _log(f"{source.label} is not reused: {why}")
        return None
    return source
