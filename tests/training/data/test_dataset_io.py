"""Dataset files: same seed -> same bytes, no pickle, counts that add up, tampering refused."""
import argparse
import json
import zipfile

import numpy as np
import pytest

from impactnet.models.contacts import CONTACT_TYPES
from impactnet.models.geometry import box_features as bf
from impactnet.models.scenes import load_scene
from impactnet.training.data import cli as datagen_cli
from impactnet.training.data.datagen import GENERATOR_VERSION, DatagenConfig, generate_dataset
from impactnet.training.data.dataset_io import ZIP_DATE_TIME, DatasetError, load_dataset, write_npz

CONFIG = DatagenConfig(chunk_size=100)

#: Which feature kinds (of A, of B) each contact type joins.
KINDS = {"vertex-face": ("vertex", "face"), "face-vertex": ("face", "vertex"),
         "edge-edge": ("edge", "edge"), "edge-face": ("edge", "face"),
         "face-edge": ("face", "edge"), "face-face": ("face", "face"),
         "none": ("none", "none")}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The paper scene and the default scene, written once (small)."""
    folder = tmp_path_factory.mktemp("data")
    generate_dataset("paper", 500, 3, CONFIG, folder, progress=False)
    generate_dataset(load_scene("quay_crane"), 250, 3, CONFIG, folder, progress=False)
    return folder


def test_same_seed_same_bytes_other_seed_other_bytes(written, tmp_path):
    for sub, seed in (("again", 3), ("other", 4)):
        generate_dataset("paper", 500, seed, CONFIG, tmp_path / sub, progress=False)
    for suffix in (".npz", ".json"):
        reference = (written / f"paper{suffix}").read_bytes()
        assert (tmp_path / "again" / f"paper{suffix}").read_bytes() == reference
        assert (tmp_path / "other" / f"paper{suffix}").read_bytes() != reference


def test_no_pickle_fixed_dates_and_stored_entries(written):
    path = written / "quay_crane.npz"
    with np.load(path, allow_pickle=False) as archive:
        assert archive.files[-1] == "pair_index"
        for key in archive.files:
            assert not archive[key].dtype.hasobject
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            assert info.date_time == ZIP_DATE_TIME
            assert info.compress_type == zipfile.ZIP_STORED
    with pytest.raises(TypeError, match="pickle"):
        write_npz(written / "bad.npz", {"x": np.array([{}, None])})


def test_manifest_records_provenance_and_counts_that_add_up(written):
    arrays, manifest = load_dataset(written / "quay_crane.json")
    scene = load_scene("quay_crane")
    assert manifest["seed"] == 3 and manifest["generator_version"] == GENERATOR_VERSION
    assert manifest["scene"] == {"name": "quay_crane", "hash": scene.hash(),
                                 "depth_fraction": [0.0, 0.01]}
    assert manifest["config"]["chunk_size"] == 100
    assert manifest["rows"] == 250 * len(scene.pairs) == len(arrays["pair_index"])
    totals = dict.fromkeys(CONTACT_TYPES, 0)
    for k, pair in enumerate(manifest["pairs"]):
        assert (pair["a"], pair["b"]) == (scene.pairs[k].a, scene.pairs[k].b)
        assert pair["size_a"] == list(scene.body(pair["a"]).size)
        assert pair["rows"] == 250 == (arrays["pair_index"] == k).sum()
        assert sum(pair["contact_types"].values()) == pair["rows"]
        assert sum(pair["families"].values()) == pair["rows"]
        assert sum(count for *_, count in pair["regions"]) == pair["rows"]
        assert pair["separated"] == pair["pushed_out"] == pair["contact_types"]["none"]
        for name, feature_a, feature_b, _ in pair["regions"]:
            assert (str(bf.feature_kind(feature_a)),
                    str(bf.feature_kind(feature_b))) == KINDS[name]
        for name, count in pair["contact_types"].items():
            totals[name] += count
    assert manifest["totals"]["contact_types"] == totals
    assert manifest["totals"]["rows"] == manifest["rows"]


def test_every_stored_column_matches_its_manifest_spec(written):
    arrays, manifest = load_dataset(written / "paper")
    assert list(arrays) == list(manifest["columns"])
    for name, spec in manifest["columns"].items():
        assert arrays[name].dtype.str == spec["dtype"]
        assert list(arrays[name].shape) == spec["shape"]


def copy_dataset(source, target, name="paper"):
    for suffix in (".npz", ".json"):
        (target / f"{name}{suffix}").write_bytes((source / f"{name}{suffix}").read_bytes())
    return target / name


def test_tampered_npz_is_refused(written, tmp_path):
    stem = copy_dataset(written, tmp_path)
    data = bytearray(stem.with_suffix(".npz").read_bytes())
    data[len(data) // 2] ^= 0x01
    stem.with_suffix(".npz").write_bytes(bytes(data))
    with pytest.raises(DatasetError, match="SHA-256"):
        load_dataset(stem)


def test_tampered_manifest_counts_are_refused(written, tmp_path):
    stem = copy_dataset(written, tmp_path)
    manifest = json.loads(stem.with_suffix(".json").read_text())
    manifest["pairs"][0]["contact_types"]["edge-edge"] += 1
    manifest["pairs"][0]["contact_types"]["vertex-face"] -= 1
    stem.with_suffix(".json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError, match="counts"):
        load_dataset(stem)


def test_missing_files_are_refused(written, tmp_path):
    stem = copy_dataset(written, tmp_path)
    stem.with_suffix(".json").unlink()
    with pytest.raises(DatasetError, match="no such file"):
        load_dataset(stem.with_suffix(".npz"))


def parse(argv):
    parser = argparse.ArgumentParser()
    datagen_cli.add_arguments(parser)
    return parser.parse_args(argv)


def test_cli_writes_the_dataset_and_a_summary(tmp_path, capsys):
    status = datagen_cli.run(parse(["--scene", "paper", "--n-per-pair", "2e2", "--seed", "1",
                                    "--out", str(tmp_path), "--no-progress",
                                    "--chunk-size", "64", "--depth-fraction", "0", "0.02"]))
    assert status == 0
    out = capsys.readouterr().out
    assert "cube/cube: 200 rows" in out and "paper.npz" in out
    _, manifest = load_dataset(tmp_path / "paper.npz")
    assert manifest["depth_fraction"] == [0.0, 0.02] and manifest["config"]["chunk_size"] == 64


@pytest.mark.parametrize("argv, message", [
    (["--scene", "no_such_scene"], "no such scene file"),
    (["--seed", "-1"], "seed"),
    (["--separated-share", "1.5"], "separated_share"),
    (["--depth-fraction", "0.02", "0.01"], "depth_fraction"),
])
def test_cli_refuses_bad_arguments(argv, message, tmp_path, capsys):
    assert datagen_cli.run(parse(argv + ["--out", str(tmp_path)])) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_cli_refuses_a_fractional_row_count():
    with pytest.raises(SystemExit):
        parse(["--n-per-pair", "10.5"])


@pytest.mark.parametrize("text", ["not json", "{}", '{"format": "impactnet-contact-dataset"}'])
def test_unreadable_manifest_is_refused(written, tmp_path, text):
    stem = copy_dataset(written, tmp_path)
    stem.with_suffix(".json").write_text(text)
    with pytest.raises(DatasetError, match="manifest"):
        load_dataset(stem)
