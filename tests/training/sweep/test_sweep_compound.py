"""`impactnet sweep` on a scene of compound pairs: the trials train the learned path of the
pair and record the same objectives (fallback share, p99 error, measured cost) and whether
they meet the tolerance; a pick is not published (`--out` is refused, naming the way)."""
from __future__ import annotations

import optuna

from impactnet.cli import main
from impactnet.training.sweep.run import SweepConfig, open_study, state_counts
from tests.compound_bundle import guide_scene


def test_a_tiny_compound_sweep_completes_with_the_three_objectives(tmp_path, capsys):
    scene = guide_scene(tmp_path)
    work = tmp_path / "work"
    status = main(["sweep", "--study", "guide", "--scene", str(scene), "--quick", "--trials",
                   "2", "--workdir", str(work), "--timing-rows", "500", "--sampler-seed", "0"])
    assert status == 0
    storage = f"sqlite:///{(work / 'study.sqlite3').as_posix()}"
    study = open_study(SweepConfig(study="guide", storage=storage, workdir=work))
    assert state_counts(study)["COMPLETE"] == 2
    for trial in study.get_trials(states=(optuna.trial.TrialState.COMPLETE,)):
        fallback, point, cost = trial.values
        assert 0.0 <= fallback <= 1.0 and point >= 0.0 and cost > 0.0
        assert isinstance(trial.user_attrs["meets"], bool)
        assert trial.user_attrs["pairs"] == ["cell_guide/container40"]
        assert set(trial.params) == {"width", "depth", "members", "expert_width"}
    assert (work / "report.md").is_file()


def test_publishing_a_compound_pick_is_refused_with_the_way_to_train_it(tmp_path, capsys):
    scene = guide_scene(tmp_path)
    status = main(["sweep", "--study", "g", "--scene", str(scene), "--quick", "--trials", "1",
                   "--workdir", str(tmp_path / "w"), "--out", str(tmp_path / "store")])
    assert status == 2
    assert "impactnet train" in capsys.readouterr().err
