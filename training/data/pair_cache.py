"""A per-pair cache of trained pairs: reuse of unchanged pairs, and resume after an interruption.

A pair's result (:class:`impactnet.training.fit.pair.PairResult`) depends only on what
:func:`pair_key` hashes, so a cached result with the same key *is* the result that training would
produce:

- the pair's body names (its seed stream, :func:`impactnet.training.data.datagen.pair_seed`) and
sizes,
- the scene's depth range and accuracy (the data, the experts' tolerances, the calibration),
- the whole :class:`impactnet.training.fit.pair.PairTrainConfig` (seed, data, single, committee) as
JSON,
- :data:`CACHE_FORMAT` and a fingerprint of the training code (:func:`code_fingerprint`: the
  SHA-256 of every ``models`` / ``training`` module that ``impactnet.training.fit.pair`` imports,
  transitively), so an edit of the training code retrains instead of reusing stale models.

The pair's position in the scene is not hashed: tensor and network names carry the pair's index
(``p3_r2_m0``), and :func:`reprefix` renames them when a pair moves.

Storage: one folder per key, ``<root>/<key>/`` with ``tensors.safetensors`` (the networks),
``rows.safetensors`` (the per-row test record that scene figures pool) and ``entry.json``
(network specs, manifest block, seconds, the index it was trained at). Never pickle. Entries are
written to a temporary folder and renamed into place, so a killed job leaves either a whole
entry or none: the finished pairs of an interrupted job are exactly what the rerun reuses.
"""
from __future__ import annotations

import ast
import dataclasses
import hashlib
import importlib.util
import json
import os
import shutil
import uuid
from functools import lru_cache
from pathlib import Path

import safetensors.numpy

from impactnet.models.scenes import Scene
from impactnet.training.fit.pair import PairResult, PairTrainConfig

#: Version of the entry layout; bump it when the files or their meaning change.
CACHE_FORMAT = 1
#: Packages whose modules the code fingerprint follows (the project's own code).
_OWN_PACKAGES = ("models", "training")
_TENSORS, _ROWS, _ENTRY = "tensors.safetensors", "rows.safetensors", "entry.json"


def plain(value):
    """Dataclasses and tuples as JSON-ready dicts and lists (inf as None)."""
    if dataclasses.is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple | list):
        return [plain(v) for v in value]
    if isinstance(value, float) and value == float("inf"):
        return None
    return value


def _own_imports(name: str) -> set[str]:
    """Modules of :data:`_OWN_PACKAGES` that module ``name`` imports (static, from its source)."""
    spec = importlib.util.find_spec(name)
    tree = ast.parse(Path(spec.origin).read_text(encoding="utf-8"))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:  # `from models import canonical`
            found.update([node.module, *(f"{node.module}.{a.name}" for a in node.names)])
    return {n for n in found if n.split(".")[0] in _OWN_PACKAGES and _is_module(n)}


def _is_module(name: str) -> bool:
    """True where ``name`` is an importable module (not a class or function of one)."""
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


@lru_cache(maxsize=1)
def code_fingerprint(root: str = "impactnet.training.fit.pair") -> str:
    """SHA-256 over the sources of ``root`` and every own module it imports, transitively."""
    seen, todo = set(), [root]
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo.extend(_own_imports(name) - seen)
    digest = hashlib.sha256()
    for name in sorted(seen):
        digest.update(name.encode() + b"\0")
        digest.update(Path(importlib.util.find_spec(name).origin).read_bytes())
    return digest.hexdigest()


def pair_key(scene: Scene, index: int, config: PairTrainConfig) -> str:
    """The cache key of ``scene.pairs[index]`` trained with ``config`` (module docstring)."""
    pair = scene.pairs[index]
    size_a, size_b = scene.pair_sizes()[index]
    what = {"format": CACHE_FORMAT, "code": code_fingerprint(), "a": pair.a, "b": pair.b,
            "size_a": [float(v) for v in size_a], "size_b": [float(v) for v in size_b],
            "depth_fraction": list(scene.depth_fraction), "accuracy": plain(scene.accuracy),
            "config": plain(config)}
    text = json.dumps(what, sort_keys=True, allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _rename(value, names: dict[str, str]):
    """``value`` with every string that is a key of ``names`` replaced, recursively."""
    if isinstance(value, str):
        return names.get(value, value)
    if isinstance(value, list):
        return [_rename(v, names) for v in value]
    if isinstance(value, dict):
        return {k: _rename(v, names) for k, v in value.items()}
    return value


def reprefix(result: PairResult, old: int, new: int) -> PairResult:
    """``result`` trained as pair ``old`` of its scene, renamed as pair ``new``."""
    if old == new:
        return result
    before, after = f"p{old}_", f"p{new}_"
    names = {n: after + n[len(before):] for n in result.mlps if n.startswith(before)}
    tensors = {}
    for key, array in result.tensors.items():
        net, _, part = key.rpartition(".")
        tensors[f"{names.get(net, net)}.{part}"] = array
    mlps = {names.get(n, n): spec for n, spec in result.mlps.items()}
    return dataclasses.replace(result, tensors=tensors, mlps=mlps,
                               block=_rename(result.block, names))


class PairCache:
    """Trained pairs under ``root`` (see the module docstring).

    Parameters
    ----------
    root : str or PathLike
        The cache folder (created on the first write).
    """

    def __init__(self, root) -> None:
        self.root = Path(root)

    @property
    def label(self) -> str:
        """Where a reused pair comes from, for messages."""
        return str(self.root)

    def get(self, scene: Scene, index: int, config: PairTrainConfig) -> PairResult | None:
        """The cached result of the pair, renamed for ``index``; None where there is none."""
        folder = self.root / pair_key(scene, index, config)
        try:
            entry = json.loads((folder / _ENTRY).read_text(encoding="utf-8"))
            tensors = safetensors.numpy.load_file(str(folder / _TENSORS))
            rows = safetensors.numpy.load_file(str(folder / _ROWS))
        except Exception:  # noqa: BLE001 - safetensors' errors derive from Exception only
            return None  # no entry (or a damaged one, which is retrained and overwritten)
        if entry.get("format") != CACHE_FORMAT or entry.get("key") != scene.pairs[index].key:
            return None
        result = PairResult(entry["key"], tensors, entry["mlps"], entry["block"],
                            float(entry["seconds"]), rows)
        return reprefix(result, int(entry["index"]), index)

    def put(self, scene: Scene, index: int, config: PairTrainConfig,
            result: PairResult) -> Path:
        """Store ``result`` (pair ``index`` of ``scene``) atomically; returns its folder."""
        folder = self.root / pair_key(scene, index, config)
        entry = {"format": CACHE_FORMAT, "key": result.key, "index": index,
                 "seconds": result.seconds, "mlps": result.mlps, "block": result.block,
                 "config": plain(config)}
        text = json.dumps(entry, indent=1, sort_keys=True, allow_nan=False)
        self.root.mkdir(parents=True, exist_ok=True)
        tmp = self.root / f".{folder.name}.tmp-{uuid.uuid4().hex[:12]}"
        tmp.mkdir()
        try:
            safetensors.numpy.save_file(dict(result.tensors), str(tmp / _TENSORS))
            safetensors.numpy.save_file(dict(result.test_rows), str(tmp / _ROWS))
            (tmp / _ENTRY).write_text(text + "\n", encoding="utf-8")
            for name in (_TENSORS, _ROWS, _ENTRY):  # on disk before the rename makes it valid
                with open(tmp / name, "rb") as handle:
                    os.fsync(handle.fileno())
            shutil.rmtree(folder, ignore_errors=True)  # a damaged entry of the same key
            os.rename(tmp, folder)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return folder

    def clear(self) -> None:
        """Delete every entry."""
        shutil.rmtree(self.root, ignore_errors=True)
