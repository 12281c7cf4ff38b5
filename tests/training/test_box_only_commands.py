"""A scene that mixes box and compound pairs is refused by train, evaluate and sweep with an
error naming the compound pairs, before any work (a scene of compound pairs only goes to their
own learned path, tests/training/compound); the box trainer and the box data generator refuse
compound pairs as a library: no box model of an envelope."""
from __future__ import annotations

import argparse
import os

import pytest

from impactnet.models.scenes import SceneError, load_scene

SCENE = "quay_crane_detail"
NAMED = "container40/container40, container40/container20, container40/spreader"


def mixed_scene(folder) -> str:
    """quay_crane_detail with a pair of plain boxes added, as a TOML file in ``folder``."""
    from impactnet.models.scenes import scene_path

    text = scene_path(SCENE).read_text().replace('name = "quay_crane_detail"', 'name = "mixed"')
    text += ('\n[bodies.crate]\nsize = [1.0, 1.0, 1.0]\n\n[[pairs]]\na = "crate"\n'
             'b = "crate"\n')
    path = folder / "mixed.toml"
    path.write_text(text)
    return str(path)


def _run(module, argv):
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)
    return module.run(parser.parse_args(argv))


@pytest.mark.parametrize("command", ["train", "evaluate", "sweep"])
def test_a_scene_mixing_box_and_compound_pairs_is_refused_naming_them(command, tmp_path,
                                                                      capsys, monkeypatch):
    from impactnet.training.bench.timing import THREAD_VARIABLES
    from impactnet.training.evaluate import cli as evaluate_cli
    from impactnet.training.jobs import cli as train_cli
    from impactnet.training.sweep import cli as sweep_cli

    scene = mixed_scene(tmp_path)
    module, argv = {
        "train": (train_cli, ["--scene", scene, "--out", str(tmp_path / "b"), "--quick"]),
        "evaluate": (evaluate_cli, ["--scene", scene, "--out", str(tmp_path / "e")]),
        "sweep": (sweep_cli, ["--study", "s", "--scene", scene, "--workdir", str(tmp_path),
                              "--quick"]),
    }[command]
    for name in THREAD_VARIABLES:  # evaluate pins BLAS threads in os.environ: restore them
        monkeypatch.setenv(name, os.environ.get(name, "1"))
    assert _run(module, argv) == 2
    err = capsys.readouterr().err
    assert f"impactnet {command} handles pairs of boxes only" in err and NAMED in err
    assert not (tmp_path / "b").exists()


def test_training_and_box_datagen_refuse_compound_pairs_as_a_library(tmp_path):
    from impactnet.training.data.datagen import generate_dataset
    from impactnet.training.jobs.scene import quick_config, train_pairs

    scene = load_scene(SCENE)
    with pytest.raises(SceneError, match=f"train_pairs handles pairs of boxes only; {NAMED}"):
        train_pairs(scene, quick_config(0), progress=False)
    with pytest.raises(SceneError, match="container40/container40"):
        generate_dataset(scene, 10, 0, out_dir=tmp_path, progress=False)
