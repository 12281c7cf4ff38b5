"""Bundles: round trip, refusal of anything altered or inconsistent, atomic replacement."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest
import safetensors.numpy

from impactnet.models.bundle import format as bd
from impactnet.models.bundle.format import BundleError
from impactnet.models.learned.bundle_loader import read_bundle, write_bundle
from tests.models.learned.test_mlp import random_mlp

REGIONS = ["none", "face-vertex:0:18", "edge-edge:6:6"]


def content(seed=0, k=2):
    """(manifest, tensors) of a one-pair bundle of random MLPs."""
    mlps = {"p.single": random_mlp((12, 16, 7), seed=seed),
            "p.logits": random_mlp((12, 16, 3), seed=seed + 1, classifier=True)}
    experts = {}
    for r, region in enumerate(REGIONS[1:]):
        experts[region] = [f"p.e{r}.{i}" for i in range(k)]
        for i, name in enumerate(experts[region]):
            mlps[name] = random_mlp((12, 8, 7), "relu", seed=seed + 10 + 3 * r + i,
                                    outputs="contact-residual-v1")
    manifest = {
        "version": f"test-{seed}", "scene": {"name": "t", "hash": "ab" * 32},
        "mlps": {name: m.spec.to_dict() for name, m in mlps.items()},
        "pairs": {"a/b": {"size_a": [1.0, 2.0, 3.0], "size_b": [2.0, 2.0, 2.0],
                          "depth_fraction": [0.0, 0.01], "single": "p.single",
                          "classifier": {"labeller": "exact-sat-v1", "regions": REGIONS},
                          "experts": experts,
                          "auto": {"confidence_min": 0.9, "normal_spread_max_deg": 0.5,
                                   "point_spread_max": 0.01, "depth_margin": 0.002}}}}
    tensors = {}
    for name, m in mlps.items():
        tensors.update(m.to_tensors(name))
    return manifest, tensors, mlps


@pytest.fixture
def written(tmp_path):
    manifest, tensors, mlps = content()
    return write_bundle(tmp_path / "bundle", manifest, tensors), manifest, mlps


def test_round_trip_gives_identical_outputs(written):
    folder, manifest, mlps = written
    assert sorted(p.name for p in folder.iterdir()) == ["manifest.json", "weights.safetensors"]
    bundle = read_bundle(folder)
    assert bundle.version == "test-0" and bundle.path == folder
    assert bundle.manifest["pairs"] == manifest["pairs"]
    assert bundle.manifest["format"] == bd.FORMAT and bundle.manifest["format_version"] == 2
    x = np.random.default_rng(0).normal(size=(100, 12))
    for name, model in mlps.items():
        np.testing.assert_array_equal(bundle.mlps[name](x), model(x))
    pair = bundle.pairs["a/b"]
    assert pair.regions == tuple(REGIONS) and pair.auto.confidence_min == 0.9
    assert pair.experts["edge-edge:6:6"] == ("p.e1.0", "p.e1.1")


def _rewrite_manifest(folder, change):
    manifest = json.loads((folder / bd.MANIFEST).read_text())
    change(manifest)
    (folder / bd.MANIFEST).write_text(json.dumps(manifest))


def test_a_flipped_byte_is_refused(written):
    folder = written[0]
    data = bytearray((folder / bd.WEIGHTS).read_bytes())
    data[-10] ^= 0x40
    (folder / bd.WEIGHTS).write_bytes(bytes(data))
    with pytest.raises(BundleError, match="SHA-256"):
        read_bundle(folder)


def test_a_truncated_file_is_refused(written):
    folder = written[0]
    (folder / bd.WEIGHTS).write_bytes((folder / bd.WEIGHTS).read_bytes()[:-4])
    with pytest.raises(BundleError, match="size or SHA-256"):
        read_bundle(folder)


def test_missing_and_extra_files_are_refused(written):
    folder = written[0]
    (folder / "notes.txt").write_text("hello")
    with pytest.raises(BundleError, match=r"extra \['notes.txt'\]"):
        read_bundle(folder)
    (folder / "notes.txt").unlink()
    (folder / bd.WEIGHTS).unlink()
    with pytest.raises(BundleError, match=r"missing \['weights.safetensors'\]"):
        read_bundle(folder)
    (folder / bd.MANIFEST).unlink()
    with pytest.raises(BundleError, match="no manifest.json"):
        read_bundle(folder)
    with pytest.raises(BundleError, match="no such bundle"):
        read_bundle(folder / "nowhere")


@pytest.mark.parametrize("change, message", [
    (lambda m: m["pairs"]["a/b"].update(single="p.gone"), "no MLP 'p.gone'"),
    (lambda m: m["pairs"]["a/b"]["experts"]["edge-edge:6:6"].append("p.gone"), "no MLP"),
    (lambda m: m["pairs"]["a/b"]["experts"].pop("edge-edge:6:6"), "one committee per region"),
    (lambda m: m["pairs"]["a/b"]["classifier"]["regions"].reverse(), "'none' first"),
    (lambda m: m["pairs"]["a/b"].update(single="p.logits"), "3 outputs, needs 7"),
    (lambda m: m["pairs"]["a/b"].update(single="p.e0.0"), "must give contact-v1"),
    (lambda m: m["pairs"]["a/b"]["experts"]["edge-edge:6:6"].append("p.single"),
     "must give contact-residual-v1"),
    (lambda m: m["pairs"]["a/b"]["classifier"].update(labeller="mlp"), "not 'exact-sat-v1'"),
    (lambda m: m["pairs"]["a/b"]["classifier"].update(mlp="p.logits"), "'labeller', 'regions'"),
    (lambda m: m["mlps"]["p.single"].update(layers=[12, 17, 7]), "shape"),
    (lambda m: m["mlps"].pop("p.single"), "no declared MLP"),
    (lambda m: m["pairs"]["a/b"].update(depth_fraction=[0.1, 0.0]), "depth_fraction"),
    (lambda m: m["pairs"]["a/b"]["auto"].pop("depth_margin"), "auto"),
    (lambda m: m.update(format_version=1), "version 2"),
    (lambda m: m.update(format="zip"), "impactnet-bundle"),
])
def test_inconsistent_manifests_are_refused(written, change, message):
    folder = written[0]
    _rewrite_manifest(folder, change)
    with pytest.raises(BundleError, match=message):
        read_bundle(folder)


def test_writing_an_inconsistent_bundle_is_refused_and_writes_nothing(tmp_path):
    manifest, tensors, _ = content()
    manifest["pairs"]["a/b"]["single"] = "p.gone"
    with pytest.raises(BundleError, match="no MLP 'p.gone'"):
        write_bundle(tmp_path / "bundle", manifest, tensors)
    manifest, tensors, _ = content()
    tensors["stray.w0"] = np.zeros(3, np.float32)
    with pytest.raises(BundleError, match="no declared MLP"):
        write_bundle(tmp_path / "bundle", manifest, tensors)
    assert list(tmp_path.iterdir()) == []


def test_non_float32_tensors_and_non_json_values_are_refused(written):
    folder = written[0]
    tensors = safetensors.numpy.load((folder / bd.WEIGHTS).read_bytes())
    tensors["p.single.b0"] = tensors["p.single.b0"].astype(np.float64)
    data = safetensors.numpy.save(tensors)
    (folder / bd.WEIGHTS).write_bytes(data)
    _rewrite_manifest(folder, lambda m: m["files"][bd.WEIGHTS].update(
        sha256=bd._sha256(data), bytes=len(data)))
    with pytest.raises(BundleError, match="float32"):
        read_bundle(folder)
    (folder / bd.MANIFEST).write_text('{"format": NaN}')
    with pytest.raises(BundleError, match="NaN is not JSON"):
        read_bundle(folder)


def test_a_bundle_is_replaced_whole(tmp_path):
    manifest, tensors, _ = content(seed=0)
    folder = write_bundle(tmp_path / "bundle", manifest, tensors)
    manifest2, tensors2, mlps2 = content(seed=5)
    write_bundle(folder, manifest2, tensors2)
    bundle = read_bundle(folder)
    assert bundle.version == "test-5"
    x = np.ones((2, 12))
    np.testing.assert_array_equal(bundle.mlps["p.single"](x), mlps2["p.single"](x))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bundle"]  # no leftovers


@pytest.mark.parametrize("crash", ["manifest", "rename"])
def test_a_crash_mid_write_leaves_the_previous_bundle_intact(tmp_path, monkeypatch, crash):
    manifest, tensors, mlps = content(seed=0)
    folder = write_bundle(tmp_path / "bundle", manifest, tensors)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    manifest2, tensors2, _ = content(seed=5)
    if crash == "manifest":
        real = bd.write_file

        def failing(path, data):
            if path.name == bd.MANIFEST:
                raise OSError("disk full")
            real(path, data)
        monkeypatch.setattr(bd, "write_file", failing)
    else:
        real_rename, calls = bd.os.rename, []

        def failing_rename(src, dst):
            calls.append(dst)
            if len(calls) == 2:  # the new bundle into place, after the old one moved away
                raise OSError("power cut")
            real_rename(src, dst)
        monkeypatch.setattr(bd.os, "rename", failing_rename)
    with pytest.raises(OSError):
        write_bundle(folder, copy.deepcopy(manifest2), tensors2)
    monkeypatch.undo()
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert read_bundle(folder).version == "test-0"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bundle"]
