"""The `impactnet` command line: parsing stays light, implemented commands do real work."""
import json
import subprocess
import sys

import pytest

from impactnet.cli import EXIT_NOT_IMPLEMENTED, main


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


def test_pending_subcommands_say_which_issue_brings_them(capsys):
    assert main(["sweep", "--anything"]) == EXIT_NOT_IMPLEMENTED
    assert "issue" in capsys.readouterr().err


def test_datagen_writes_a_dataset_and_its_manifest(tmp_path, capsys):
    assert main(["datagen", "--scene", "paper", "--n-per-pair", "500", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    manifest = json.loads((tmp_path / "paper.json").read_text())
    assert manifest["scene"]["name"] == "paper"
    assert manifest["rows"] == 500
    assert (tmp_path / "paper.npz").stat().st_size > 0
