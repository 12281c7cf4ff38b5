"""The files one request crosses (issue #33): every file of impactnet whose code runs for one
POST /v2/contact, compiled kernels' source files included.

A profiler hook records, for one warm request, every Python function of impactnet that runs (in
any thread) and every compiled kernel called from Python (a numba dispatcher shows as a C
call); a kernel's own callees leave no frames, so the files of the compiled functions it names
are added, transitively, from its code's names. Counted: files, not hops.

Goal of issue #33: a box pair at most 8 files, a compound pair at most 10. NOT MET: measured at
the round that wrote this test, 27 and 36 (:data:`BOX_FILES`, :data:`COMPOUND_FILES`). Ten of
them are the admission and accounting every request passes whatever its body (the middleware,
five limits modules, metrics, logging, the error responder); five are the codecs (request
model, pair decoding, JSON keys, feature names, the answer's writer). The counts are held here
so that a change that adds a file fails and is seen; lower them as files are merged.
"""
from __future__ import annotations

import sys
import threading
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from impactnet.models import compiled
from impactnet.service.app import create_app
from tests.service.conftest import test_settings

REPO = Path(__file__).resolve().parents[2]
BOX = {"a": {"object": "container40", "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
       "b": {"object": "spreader", "position": [0.3, 0.1, 1.69], "quaternion": [1, 0, 0, 0]},
       "mode": "exact"}
COMPOUND = {"a": {"object": "container40", "position": [0, 0, 1.2955],
                  "quaternion": [1, 0, 0, 0]},
            "b": {"object": "spreader", "position": [0.0, 0.0, 3.0], "euler": [0, 0, 0.01]},
            "mode": "exact"}


class Files:
    """A profiler hook: the repository files whose code runs while ``active``."""

    def __init__(self) -> None:
        self.root, self.files, self.kernels, self.active = str(REPO) + "/", set(), [], False

    def _ours(self, path: str) -> bool:
        return path.startswith(self.root) and "/.venv/" not in path and "/tests/" not in path

    def __call__(self, frame, event, arg):
        if not self.active:
            return
        if event == "call" and self._ours(frame.f_code.co_filename):
            self.files.add(frame.f_code.co_filename[len(self.root):])
        elif event == "c_call" and isinstance(arg, compiled.numba.core.registry.CPUDispatcher):
            self.kernels.append(arg)

    def kernel_files(self) -> set[str]:
        """The files of the kernels called and of every compiled function they name."""
        seen, files, todo = set(), set(), list(self.kernels)
        while todo:
            kernel = todo.pop()
            if id(kernel) in seen:
                continue
            seen.add(id(kernel))
            code = kernel.py_func.__code__
            if self._ours(code.co_filename):
                files.add(code.co_filename[len(self.root):])
            names = set(code.co_names)
            for const in code.co_consts:  # nested code (closures) names its callees too
                names |= set(getattr(const, "co_names", ()))
            scope = kernel.py_func.__globals__
            for name in names:
                value = scope.get(name)
                if isinstance(value, compiled.numba.core.registry.CPUDispatcher):
                    todo.append(value)
                elif hasattr(value, "__dict__") and not callable(value):  # a module
                    todo += [v for v in vars(value).values()
                             if isinstance(v, compiled.numba.core.registry.CPUDispatcher)]
        return files


def crossed(scene: str, body: dict) -> list[str]:
    """The files one warm request crosses (module docstring)."""
    recorder = Files()
    threading.setprofile(recorder)
    try:
        with TestClient(create_app(test_settings(scene=scene))) as client:
            assert client.post("/v2/contact", json=body).status_code == 200  # warm
            sys.setprofile(recorder)
            recorder.active = True
            assert client.post("/v2/contact", json=body).status_code == 200
            recorder.active = False
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    return sorted(recorder.files | recorder.kernel_files())


#: Files a box pair crosses today (the issue's goal: 8).
BOX_FILES = 27
#: Files a compound pair crosses today (the issue's goal: 10).
COMPOUND_FILES = 36


@pytest.mark.parametrize("scene, body, measured", [
    ("quay_crane", BOX, BOX_FILES), ("quay_crane_detail", COMPOUND, COMPOUND_FILES)])
def test_one_contact_crosses_no_more_files_than_measured(scene, body, measured):
    files = crossed(scene, body)
    print(len(files), *files, sep="\n")
    assert len(files) <= measured, "\n".join(files)
