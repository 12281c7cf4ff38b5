"""The Docker runtime stage without Docker: wheels of the project (no extras), installed into
a fresh virtualenv, must serve /readyz and /v1/contact with no torch installed; when the
repository ships the default scene's bundle, the installed package serves it (mode auto)."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import urllib.request

import pytest

from tests.service.conftest import PAIR, REPO, ServerProcess

# What docker/Dockerfile copies into the build stage.
COPIED = ["pyproject.toml", "README.md", "impactnet", "models", "training", "service"]
# Folders of a bundle store that docker/Dockerfile.dockerignore leaves out of the build context.
STORE_EXCLUDED = (".cache", "rejected")
_IGNORED = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")


def _ignore(folder: str, names: list[str]) -> set[str]:
    """What the Docker build context leaves out of ``folder`` (a copytree ``ignore``)."""
    ignored = set(_IGNORED(folder, names))
    if os.path.dirname(os.path.abspath(folder)) == str(REPO / "models" / "bundles"):
        ignored |= set(names) & set(STORE_EXCLUDED)
    return ignored


def _run(*cmd, **kwargs):
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=900, **kwargs)
    assert result.returncode == 0, f"{cmd}: {result.stdout[-2000:]}\n{result.stderr[-4000:]}"
    return result.stdout


@pytest.mark.slow
def test_runtime_install_serves_without_torch(tmp_path):
    copy_lines = [line.split()[1:-1] for line in
                  (REPO / "docker" / "Dockerfile").read_text().splitlines()
                  if line.startswith("COPY ") and "--from" not in line]
    assert sorted(p for line in copy_lines for p in line if p != "scenes") == sorted(COPIED)
    src = tmp_path / "src"
    src.mkdir()
    dockerignore = (REPO / "docker" / "Dockerfile.dockerignore").read_text().splitlines()
    assert all(f"models/bundles/*/{name}" in dockerignore for name in STORE_EXCLUDED)
    for path in COPIED:
        if (REPO / path).is_dir():
            shutil.copytree(REPO / path, src / path, ignore=_ignore)
        else:
            shutil.copy2(REPO / path, src / path)
    shutil.copytree(REPO / "scenes", tmp_path / "scenes")

    # RUN pip wheel --wheel-dir /wheels .
    _run(sys.executable, "-m", "pip", "wheel", "--quiet", "--wheel-dir",
         str(tmp_path / "wheels"), str(src))
    # RUN python -m venv /opt/venv && pip install --no-index --find-links /wheels impactnet
    venv = tmp_path / "venv"
    _run(sys.executable, "-m", "venv", str(venv))
    python = str(venv / "bin" / "python")
    _run(python, "-m", "pip", "install", "--quiet", "--no-index", "--find-links",
         str(tmp_path / "wheels"), "impactnet")
    _run(python, "-c", "import importlib.util, sys; "
         "sys.exit(importlib.util.find_spec('torch') is not None)")
    installed = _run(python, "-m", "pip", "list", "--format=json")
    names = {p["name"].lower() for p in json.loads(installed)}
    assert "torch" not in names and {"fastapi", "uvicorn", "numpy", "orjson"} <= names

    # CMD impactnet serve (python -m service until the CLI wires `serve`), outside the repo.
    workdir = tmp_path / "app"
    workdir.mkdir()
    env = {"IMPACTNET_SCENES_DIR": str(tmp_path / "scenes"), "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "PYTHONPATH": "", "PATH": f"{venv / 'bin'}:{os.environ['PATH']}"}
    shipped = (REPO / "models" / "bundles" / "quay_crane").is_dir()
    proc = ServerProcess(python=python, env=env, cwd=workdir, bundle_default=True)
    try:
        proc.wait_ready(timeout=120)

        def contact(mode: str) -> dict:
            request = urllib.request.Request(
                f"{proc.url}/v1/contact", data=json.dumps(
                    {"a": {"object": "cube", "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
                     "b": PAIR["b"], "mode": mode}).encode(),
                headers={"Content-Type": "application/json"})
            with urllib.request.urlopen(request, timeout=10) as response:
                assert response.status == 200
                return json.loads(response.read())

        answer = contact("exact")
        assert answer["colliding"] is True and answer["predictor"] == "exact"
        assert answer["contact_type"] != "none" and abs(answer["normal"][2] - 1) < 1e-9
        with urllib.request.urlopen(f"{proc.url}/v1/models", timeout=10) as response:
            models = json.loads(response.read())
        assert (models["bundle"] is not None) == shipped
        if shipped:  # the wheel carries the bundle and serves it without torch
            assert models["modes"]["default"] == "auto"
            assert contact("auto")["predictor"] in ("committee", "exact")
        _run(python, "-c", "import service.app, sys; "
             "sys.exit('torch' in sys.modules or not service.app.__file__.startswith("
             f"{str(venv)!r}))", cwd=workdir)
        assert proc.stop() == 0, proc.output()[-3000:]
    finally:
        proc.cleanup()
