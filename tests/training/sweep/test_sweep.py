"""`impactnet sweep` on SQLite: a tiny study completes, reports its Pareto front, publishes a
bundle that loads, resumes by name; the pruning rule and the search space on their own."""
from __future__ import annotations

from pathlib import Path

import optuna
import pytest

from impactnet.cli import main
from impactnet.models import load_predictor
from impactnet.models.bundle.store import current_version
from impactnet.models.scenes import scene_path
from impactnet.training.jobs.scene import quick_config
from impactnet.training.sweep.pruning import hopeless
from impactnet.training.sweep.run import SweepConfig, open_study, state_counts
from impactnet.training.sweep.space import config_from_params, quick_space, suggest

#: Loose tolerances, so that a quick model meets them and a pick exists.
LOOSE = {"normal_deg = 1.0": "normal_deg = 30.0", "point_fraction = 0.02": "point_fraction = 1.0",
         'name = "paper"': 'name = "loose"'}


def loose_scene(folder: Path) -> Path:
    """The paper's scene with loose tolerances, as a file in ``folder``."""
    text = scene_path("paper").read_text()
    for old, new in LOOSE.items():
        assert old in text
        text = text.replace(old, new)
    path = folder / "loose.toml"
    path.write_text(text)
    return path


def sweep_args(scene: Path, workdir: Path, trials: int, *extra: str) -> list[str]:
    return ["sweep", "--study", "tiny", "--scene", str(scene), "--quick", "--trials",
            str(trials), "--workdir", str(workdir), "--timing-rows", "2000",
            "--sampler-seed", "0", *extra]


@pytest.fixture(scope="module")
def tiny_sweep(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    scene = loose_scene(folder)
    store = folder / "store"
    status = main(sweep_args(scene, folder / "work", 3, "--out", str(store)))
    return status, scene, folder, store


def test_a_tiny_sweep_publishes_a_bundle_that_loads(tiny_sweep, capsys):
    status, _, folder, store = tiny_sweep
    assert status == 0
    assert current_version(store) is not None
    predictor = load_predictor("auto", store)
    assert predictor is not None
    assert (folder / "work" / "report.md").read_text().count("(pick)") == 1
    assert (folder / "work" / "pareto.png").stat().st_size > 0


def test_the_sweep_resumes_by_name_and_shows_its_state(tiny_sweep, capsys):
    _, scene, folder, _ = tiny_sweep
    capsys.readouterr()
    assert main(sweep_args(scene, folder / "work", 4)) == 0
    storage = f"sqlite:///{(folder / 'work' / 'study.sqlite3').as_posix()}"
    study = open_study(SweepConfig("tiny", storage, folder / "work"))
    counts = state_counts(study)
    assert counts["COMPLETE"] + counts["PRUNED"] == 4 and counts["RUNNING"] == 0
    assert sorted(t.number for t in study.trials) == list(range(len(study.trials)))
    capsys.readouterr()
    assert main(["sweep", "--study", "tiny", "--workdir", str(folder / "work"), "--show"]) == 0
    out = capsys.readouterr().out
    assert '"study": "tiny"' in out and "| trial |" in out


def test_a_study_resumed_with_other_settings_is_refused(tiny_sweep, capsys):
    _, scene, folder, _ = tiny_sweep
    assert main(sweep_args(scene, folder / "work", 4, "--seed", "9")) == 2
    assert "other settings" in capsys.readouterr().err


def test_hopeless_compares_with_the_completed_trials():
    assert not hopeless(0.9, [0.1, 0.2], startup=3, percentile=75)  # too few to judge
    assert hopeless(0.9, [0.1, 0.2, 0.3, 0.4], startup=3, percentile=75)
    assert not hopeless(0.2, [0.1, 0.2, 0.3, 0.4], startup=3, percentile=75)


def test_a_trials_config_is_rebuilt_from_its_parameters():
    base = quick_config(0).pair
    study = optuna.create_study(directions=["minimize"] * 3)
    trial = study.ask()
    drawn = suggest(trial, quick_space(), base)
    assert config_from_params(trial.params, quick_space(), base) == drawn
    assert drawn.committee.members == trial.params["members"]
    assert drawn.committee.expert_hidden == (trial.params["width"],) * trial.params["depth"]
    assert drawn.data.rows == trial.params["rows"] and drawn.seed == base.seed
