"""A scene and tiny learned bundles for the service tests (not a test module).

The bundles are those of ``tests/models/learned/learned_fixtures.py`` (closed-form fitted MLPs for a
brick/slab pair and a cube pair), with the manifest's scene set to :data:`SCENE_TOML`'s name
and hash, so that the service accepts them. The scene has one more pair, plank/cube, that no
bundle covers (strict learned modes answer 422 for it, auto falls back to exact).
"""
from __future__ import annotations

import copy
import functools
from pathlib import Path

import numpy as np

from impactnet.models.scenes import load_scene
from tests.models.learned.learned_fixtures import bundle_content, write_test_bundle

SCENE_TOML = """
[scene]
name = "svc_test"
depth_fraction = [0.0, 0.01]

[accuracy]
normal_deg = 1.0
point_fraction = 0.02

[bodies.brick]
size = [1.0, 0.6, 0.4]

[bodies.slab]
size = [2.0, 1.5, 0.3]

[bodies.cube]
size = [1.0, 1.0, 1.0]

[bodies.plank]
size = [3.0, 0.2, 0.2]

[[pairs]]
a = "brick"
b = "slab"

[[pairs]]
a = "cube"
b = "cube"

[[pairs]]
a = "plank"
b = "cube"
"""


def write_scene(folder: Path, text: str = SCENE_TOML) -> Path:
    """The test scene as ``folder/svc_test.toml``; returns its path."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "svc_test.toml"
    path.write_text(text)
    return path


#: Shift of every MLP's output mean in the nonsense bundle (outputs in units of L).
NONSENSE_SHIFT = np.float32(3.0)


@functools.lru_cache(maxsize=1)
def _content():
    return bundle_content(seed=0)


def write_bundle(folder: Path, scene_path: Path, version: str = "svc-test-1",
                 scene_hash: str | None = None, nonsense_outputs: bool = False,
                 exact_only: tuple[str, ...] = ()) -> Path:
    """The test bundle for the scene at ``scene_path`` (or with another ``scene_hash``),
    with manifest version ``version``, written to ``folder``. ``nonsense_outputs``: every
    MLP's outputs shifted by 3 (points 3 L away), a well-formed bundle (checksums fine) that
    answers nonsense and fails the smoke test. ``exact_only``: pairs whose recorded decision is
    to serve them exactly (issue #21)."""
    manifest, tensors = _content()
    if nonsense_outputs:
        tensors = {k: (v + NONSENSE_SHIFT if k.endswith(".out_mean") else v)
                   for k, v in tensors.items()}
    manifest = copy.deepcopy(manifest)
    scene = load_scene(scene_path)
    manifest["scene"] = {"name": scene.name, "hash": scene_hash or scene.hash()}
    manifest["version"] = version
    for entry in manifest["pairs"].values():
        entry["validation"] = {"region_accuracy": 0.9, "normal_median_deg": 3.0}
    for key in exact_only:
        manifest["pairs"][key]["decision"] = {"serve": "exact-only", "figures": {
            "speedup_n1": 0.9, "speedup_batch": 0.7, "fallback_share": 0.2,
            "normal_p99_deg": 0.0, "point_p99_fraction": 0.01, "poses": 100_000}}
    return write_test_bundle(folder, content=(manifest, tensors))


def corrupt(folder: Path) -> None:
    """Flip one byte in the middle of the bundle's weights."""
    weights = folder / "weights.safetensors"
    data = bytearray(weights.read_bytes())
    data[len(data) // 2] ^= 0x01
    weights.write_bytes(bytes(data))
