"""service/ never imports torch; the serve flags import nothing heavy."""
from __future__ import annotations

import subprocess
import sys

from tests.service.conftest import REPO


def _run(code: str) -> str:
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_app_import_and_answer_without_torch():
    out = _run(
        "import sys\n"
        "from fastapi.testclient import TestClient\n"
        "import impactnet.service.app, impactnet.service.client, impactnet.service.cli, "
        "impactnet.service.codecs.columns\n"
        "from impactnet.service.settings import Settings\n"
        "app = impactnet.service.app.create_app(Settings(load_in_background=False))\n"
        "with TestClient(app) as c:\n"
        "    r = c.post('/v2/contact', json={'a': {'object': 'cube', 'position': [0, 0, 0],"
        " 'quaternion': [1, 0, 0, 0]}, 'b': {'object': 'cube', 'position': [0, 0, 1.9],"
        " 'quaternion': [1, 0, 0, 0]}})\n"
        "    assert r.status_code == 200, r.text\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('torch', 'training')))\n")
    assert out.strip() == "[]"


def test_cli_module_is_light():
    out = _run("import sys, argparse\n"
               "import impactnet.service.cli\n"
               "impactnet.service.cli.add_arguments(argparse.ArgumentParser())\n"
               "print(sorted(m for m in ('numpy', 'fastapi', 'uvicorn', 'pydantic', 'torch')"
               " if m in sys.modules))\n")
    assert out.strip() == "[]"
