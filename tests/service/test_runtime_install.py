"""The wheel, installed as a user installs it, outside the source tree.

* The Docker runtime stage without Docker: wheels of the project (no extras), installed into a
  fresh virtualenv that already holds unrelated top-level packages named ``models`` and
  ``service`` (a simulator's own), must serve ``impactnet serve`` -> /readyz and /v2/contact
  with no torch, with the scene files and the shipped bundle from the wheel, and answer
  ``impactnet contact``; neither side shadows the other.
* The wheel is complete: with the training stack importable, ``impactnet bench --quick`` runs
  from the installed package (``training/bench`` and the scenes are in the wheel).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import urllib.request
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

from impactnet.models import compiled
from tests.service.conftest import PAIR, REPO, ServerProcess

# What docker/Dockerfile copies into the build stage.
COPIED = ["pyproject.toml", "setup.py", "README.md", "impactnet", "models", "training",
          "service", "scenes"]
# Folders of a bundle store that docker/Dockerfile.dockerignore leaves out of the build context.
STORE_EXCLUDED = (".cache", "rejected")
# Unrelated packages a simulator's environment may already hold (the names impactnet's
# repository folders have); they must neither shadow impactnet nor be shadowed by it.
FOREIGN_PACKAGES = ("models", "service")
# The runtime stage's environment for the compiled kernels (docker/Dockerfile's ENV lines).
KERNEL_ENV = {"NUMBA_CPU_NAME": "generic"}
# Seconds from `impactnet serve` to /readyz with the kernels cached (the goal is 60 s after
# the install; the margin absorbs a loaded CI machine's start of Python and NumPy).
READY_S = 60
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


@pytest.fixture(scope="module")
def wheel_dir(tmp_path_factory):
    """Wheels of the project and its runtime dependencies, built as docker/Dockerfile does."""
    root = tmp_path_factory.mktemp("wheel")
    copy_lines = [line.split()[1:-1] for line in
                  (REPO / "docker" / "Dockerfile").read_text().splitlines()
                  if line.startswith("COPY ") and "--from" not in line]
    assert sorted(p for line in copy_lines for p in line) == sorted(COPIED)
    dockerignore = (REPO / "docker" / "Dockerfile.dockerignore").read_text().splitlines()
    assert all(f"models/bundles/*/{name}" in dockerignore for name in STORE_EXCLUDED)
    src = root / "src"
    src.mkdir()
    for path in COPIED:
        if (REPO / path).is_dir():
            shutil.copytree(REPO / path, src / path, ignore=_ignore)
        else:
            shutil.copy2(REPO / path, src / path)
    # RUN pip wheel --wheel-dir /wheels .
    _run(sys.executable, "-m", "pip", "wheel", "--quiet", "--wheel-dir", str(root / "wheels"),
         str(src))
    return root / "wheels"


def _fresh_venv(path, wheels):
    """A virtualenv with the foreign packages, then impactnet from ``wheels`` (no index)."""
    _run(sys.executable, "-m", "venv", str(path))
    python = str(path / "bin" / "python")
    site = _run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])").strip()
    for name in FOREIGN_PACKAGES:
        os.makedirs(os.path.join(site, name))
        with open(os.path.join(site, name, "__init__.py"), "w", encoding="utf-8") as f:
            f.write(f"FOREIGN = {name!r}\n")
    _run(python, "-m", "pip", "install", "--quiet", "--no-index", "--find-links", str(wheels),
         "impactnet")
    return python, site


def _env(venv):
    return {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
            "PYTHONPATH": "", "IMPACTNET_SCENES_DIR": "", "PATH":
            f"{venv / 'bin'}:{os.environ['PATH']}"}


@pytest.mark.slow
def test_wheel_installs_everything_under_the_impactnet_namespace(wheel_dir):
    wheel = next(wheel_dir.glob("impactnet-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"impactnet"}
    for needed in ("impactnet/training/bench/runner.py", "impactnet/scenes/quay_crane.toml",
                   "impactnet/models/box/exact.py", "impactnet/service/api/routers/contact.py"):
        assert needed in names, needed
    assert any(n.startswith("impactnet/models/bundles/quay_crane/versions/") and
               n.endswith("weights.safetensors") for n in names)
    assert not any("/.cache/" in n or "/rejected/" in n for n in names)


@dataclass(frozen=True)
class Installed:
    """The wheel installed in a fresh virtualenv as docker/Dockerfile's runtime stage does,
    its kernels in their cache (the image's build step)."""

    venv: Path
    python: str
    site: str  # its site-packages
    env: dict  # the runtime stage's environment (docker/Dockerfile's ENV lines)


def _seeded_cache(folder: Path) -> None:
    """``folder`` holds the source tree's kernels, brought up to date first (a cold compile
    of every kernel takes minutes on 2 cores; ``make test``'s install has paid it)."""
    _run(sys.executable, "-m", "impactnet.models.compiled", cwd=REPO)
    shutil.copytree(compiled.cache_folder(), folder)


@pytest.fixture(scope="module")
def installed(tmp_path_factory, wheel_dir) -> Installed:
    """One install for the tests of this module, its kernel cache seeded with the source
    tree's: the cache is keyed by contents, not by where the sources lie, so the wheel's build
    step must only load them. (The image's ``NUMBA_CPU_NAME=generic`` is asserted in the
    Dockerfile here; a generic cache built ahead and loaded elsewhere is tested in
    tests/models/test_compiled.py.)"""
    root = tmp_path_factory.mktemp("installed")
    venv = root / "venv"
    python, site = _fresh_venv(venv, wheel_dir)
    _seeded_cache(root / "kernels")
    env = {**_env(venv), "IMPACTNET_KERNEL_CACHE_DIR": str(root / "kernels")}
    assert all(f"{k}={v}" in (REPO / "docker" / "Dockerfile").read_text()
               for k, v in KERNEL_ENV.items())
    # RUN python -m impactnet.models.compiled --serving: the image's build step; here every
    # kernel a request may call loads from the seeded cache.
    out = _run(python, "-m", "impactnet.models.compiled", "--serving", cwd=root, env=env)
    assert "(0 signatures compiled" in out, out
    return Installed(venv, python, site, env)


@pytest.mark.slow
def test_runtime_install_serves_without_torch_beside_foreign_models_and_service(tmp_path,
                                                                                 installed):
    venv, python, site, env = installed.venv, installed.python, installed.site, installed.env
    _run(python, "-c", "import importlib.util, sys; "
         "sys.exit(importlib.util.find_spec('torch') is not None)")
    installed_list = _run(python, "-m", "pip", "list", "--format=json")
    names = {p["name"].lower() for p in json.loads(installed_list)}
    assert "torch" not in names and {"fastapi", "uvicorn", "numpy", "orjson"} <= names
    workdir = tmp_path / "app"  # outside the source tree
    workdir.mkdir()
    # The foreign packages are still theirs, and impactnet's are its own.
    _run(python, "-c", "import models, service, impactnet.models.box.exact as e, sys; "
         "sys.exit(models.FOREIGN != 'models' or service.FOREIGN != 'service' or "
         f"not e.__file__.startswith({site!r}))", cwd=workdir, env=env)
    # impactnet contact, from the installed console script.
    answer = json.loads(_run(str(venv / "bin" / "impactnet"), "contact", cwd=workdir,
                             env={**os.environ, **env}))
    assert answer["colliding"] is True and abs(answer["normal"][2] - 1) < 0.01

    # CMD impactnet serve: the scene and the bundle come from the wheel.
    shipped = (REPO / "models" / "bundles" / "quay_crane").is_dir()
    proc = ServerProcess(env=env, cwd=workdir, bundle_default=True,
                         command=[str(venv / "bin" / "impactnet"), "serve"])
    try:
        # Kernels load from the image's cache: ready well within the 60 s the issue allows.
        proc.wait_ready(timeout=READY_S)

        def contact(mode: str) -> dict:
            request = urllib.request.Request(
                f"{proc.url}/v2/contact", data=json.dumps(
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
        # /docs offline: its assets come from the installed fastapi-offline wheel.
        with urllib.request.urlopen(f"{proc.url}/static/docs/swagger-ui-bundle.js",
                                    timeout=10) as response:
            assert response.status == 200 and len(response.read()) > 100_000
        if shipped:  # the wheel carries the bundle and serves it without torch
            assert models["modes"]["default"] == "auto"
            assert contact("auto")["predictor"] in ("committee", "exact")
        _run(python, "-c", "import impactnet.service.app, sys; "
             "sys.exit('torch' in sys.modules or not impactnet.service.app.__file__.startswith("
             f"{str(venv)!r}))", cwd=workdir, env=env)
        assert proc.stop() == 0, proc.output()[-3000:]
    finally:
        proc.cleanup()


@pytest.mark.slow
def test_installed_wheel_runs_the_quick_benchmark_outside_the_tree(tmp_path, installed):
    """``training/bench`` ships in the wheel. The training stack (torch, SciPy, python-fcl,
    matplotlib, MuJoCo) is taken from this test run's environment through a ``.pth`` line
    after the fresh site-packages (removed afterwards: the runtime test's install has no
    torch), so impactnet itself still comes from the wheel; resolving the train extra from the
    index is what ``make test``'s own install checks."""
    python, site = installed.python, installed.site
    stack = Path(site) / "zz_training_stack.pth"
    stack.write_text(sysconfig.get_paths()["purelib"] + "\n", encoding="utf-8")
    workdir = tmp_path / "run"
    workdir.mkdir()
    env = {**os.environ, **installed.env}
    try:
        _run(python, "-c", "import impactnet.training.bench.runner as r, sys; "
             f"sys.exit(not r.__file__.startswith({site!r}))", cwd=workdir, env=env)
        out = _run(str(installed.venv / "bin" / "impactnet"), "bench", "--quick", "--out",
                   str(workdir / "bench"), cwd=workdir, env=env)
    finally:
        stack.unlink()
    assert "exact" in out
    assert (workdir / "bench" / "results.json").is_file()
