"""The box-only commands (train, evaluate, sweep) and the box data generator refuse a scene's
compound pairs with an error naming them, before any work: no box model of an envelope."""
from __future__ import annotations

import argparse
import os

import pytest

from impactnet.models.scenes import SceneError, load_scene

SCENE = "quay_crane_detail"
NAMED = "container40/container40, container40/container20, container40/spreader"


def _run(module, argv):
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)
    return module.run(parser.parse_args(argv))


@pytest.mark.parametrize("command", ["train", "evaluate", "sweep"])
def test_a_box_only_command_refuses_the_detail_scene_naming_its_pairs(command, tmp_path,
                                                                       capsys, monkeypatch):
    from impactnet.training.bench.timing import THREAD_VARIABLES
    from impactnet.training.evaluate import cli as evaluate_cli
    from impactnet.training.jobs import cli as train_cli
    from impactnet.training.sweep import cli as sweep_cli

    module, argv = {
        "train": (train_cli, ["--scene", SCENE, "--out", str(tmp_path / "b"), "--quick"]),
        "evaluate": (evaluate_cli, ["--scene", SCENE, "--out", str(tmp_path / "e")]),
        "sweep": (sweep_cli, ["--study", "s", "--scene", SCENE, "--workdir", str(tmp_path),
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
