"""The `impactnet` command line: parsing stays light, implemented commands do real work."""
import json
import subprocess
import sys

import pytest

from impactnet.cli import main


def test_building_the_parser_imports_nothing_heavy():
    code = ("import sys; from impactnet.cli import build_parser; build_parser(); "
            "print(sorted(m for m in ('numpy', 'torch', 'fastapi') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_contact_prints_the_exact_answer_as_json(capsys):
    assert main(["contact", "--position-b", "0", "0", "1.9", "--quaternion-b", "1", "0", "0",
                 "0"]) == 0
    body = json.loads(capsys.readouterr().out)
    assert body["colliding"] is True
    assert body["contact_type"] == "face-face"
    assert body["depth"] == pytest.approx(0.1)
    assert body["normal"] == pytest.approx([0, 0, 1])
    assert body["point"] == pytest.approx([0, 0, 0.95])


def test_sweep_is_wired_and_checks_its_arguments(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["sweep", "--help"])
    assert exit_info.value.code == 0
    assert "--storage" in capsys.readouterr().out
    with pytest.raises(SystemExit):  # --study is required
        main(["sweep", "--quick"])
    assert main(["sweep", "--study", "s", "--trials", "0", "--workdir", str(tmp_path)]) == 2
    assert "--trials must be >= 1" in capsys.readouterr().err
    assert main(["sweep", "--study", "missing", "--show", "--workdir", str(tmp_path)]) == 2
    assert "missing" in capsys.readouterr().err


def test_datagen_writes_a_dataset_and_its_manifest(tmp_path, capsys):
    assert main(["datagen", "--scene", "paper", "--n-per-pair", "500", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    manifest = json.loads((tmp_path / "paper.json").read_text())
    assert manifest["scene"]["name"] == "paper"
    assert manifest["rows"] == 500
    assert (tmp_path / "paper.npz").stat().st_size > 0


@pytest.mark.parametrize("extra, message", [
    (["--bundle", "/nonexistent/bundle"], "no bundle at /nonexistent/bundle"),
    (["--rows", "0"], "--rows must be >= 1"),
    (["--seed", "-1"], "--seed must be >= 0"),
    (["--scene", "no_such_scene"], "no_such_scene"),
])
def test_evaluate_rejects_bad_arguments_with_status_2(tmp_path, capsys, extra, message):
    assert main(["evaluate", "--out", str(tmp_path), "--quick", *extra]) == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing written
