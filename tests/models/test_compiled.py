"""The compiled core's common ground (models/compiled.py): chunks stop at the work limit,
parallel launches are safe from many threads at once, the cache folder is writable wherever
the package is installed and is keyed by contents (a cache built ahead for a generic CPU loads
in another process and another folder), warm-ups run once registered."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from impactnet.models import compiled
from impactnet.models.work import WorkLimit, WorkStopped, limited
from tests.models.helpers import in_threads


@compiled.parallel_jit
def _row_sums(values, out):
    for i in compiled.numba.prange(values.shape[0]):
        total = 0.0
        for j in range(values.shape[1]):
            total += values[i, j] * values[i, j]
        out[i] = total


def test_chunks_cover_every_row_once_in_order():
    assert list(compiled.chunks(10, 4)) == [(0, 4), (4, 8), (8, 10)]
    assert list(compiled.chunks(0, 4)) == []


def test_chunks_stop_when_the_work_limit_is_cancelled():
    limit = WorkLimit()
    seen = []
    with limited(limit), pytest.raises(WorkStopped) as stopped:
        for start, _ in compiled.chunks(100, 10):
            seen.append(start)
            if start == 20:
                limit.cancel()
    assert seen == [0, 10, 20] and stopped.value.reason == "cancelled"


def test_eight_threads_launching_parallel_kernels_at_once_get_the_serial_answers():
    values = np.random.default_rng(0).normal(size=(20_000, 16))
    expected = (values * values).sum(axis=1)

    def run(k: int) -> np.ndarray:
        out = np.empty(len(values))
        for _ in range(5):
            compiled.launch(_row_sums, values, out)
        return out

    for out in in_threads(run, timeout=60):
        np.testing.assert_allclose(out, expected, rtol=1e-13)


def test_the_cache_folder_is_the_setting_else_a_writable_user_folder(monkeypatch, tmp_path):
    monkeypatch.setenv(compiled.CACHE_ENV, str(tmp_path / "given"))
    assert compiled.cache_folder() == tmp_path / "given"
    monkeypatch.delenv(compiled.CACHE_ENV)
    real, sources = compiled._writable, str(Path(compiled.__file__).resolve().parent)
    monkeypatch.setattr(compiled, "_writable",  # a read-only install: beside the sources fails
                        lambda folder: not str(folder).startswith(sources) and real(folder))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert compiled.cache_folder() == tmp_path / "cache" / "impactnet" / "kernels"


def test_the_fingerprint_changes_with_a_file_a_kernel_may_inline(monkeypatch, tmp_path):
    root = tmp_path / "models"
    for folder in ("box", "compound", "frame"):
        (root / folder).mkdir(parents=True)
        (root / folder / "k.py").write_text("x = 1\n")
    monkeypatch.setattr(compiled, "__file__", str(root / "compiled.py"))
    before = {f: compiled.fingerprint(f) for f in ("box", "compound", "frame")}
    assert before["box"] == compiled.fingerprint("box") and len(before["box"]) == 16
    (root / "box" / "k.py").write_text("x = 2\n")  # compound kernels inline box functions
    after = {f: compiled.fingerprint(f) for f in ("box", "compound", "frame")}
    assert after["box"] != before["box"] and after["compound"] != before["compound"]
    assert after["frame"] == before["frame"]


def test_kernels_of_impactnet_are_stamped_with_their_fingerprint():
    from numba.core.caching import CacheImpl

    from impactnet.models.box import kernels

    locator = CacheImpl._locator_classes[0].from_function(kernels.solve_pair.py_func,
                                                          kernels.__file__)
    own, stamp = locator.get_source_stamp()
    assert stamp == compiled.fingerprint("box")


def test_thread_counts_stay_within_numba_s_pool():
    try:
        assert compiled.set_threads(1) == 1
        assert compiled.set_threads(10_000) == compiled.numba.config.NUMBA_NUM_THREADS
    finally:
        compiled.set_threads()


def test_warm_up_runs_every_registered_warm_up(monkeypatch):
    calls = []
    monkeypatch.setattr(compiled, "_WARM_UPS", [lambda: calls.append(1)])
    monkeypatch.setattr(compiled, "KERNEL_MODULES", ())  # a module imported now would register
    assert compiled.warm_up() == 1 and calls == [1]


def test_a_server_s_warm_up_leaves_the_library_s_own_entries_to_the_install(monkeypatch):
    calls = []
    monkeypatch.setattr(compiled, "_WARM_UPS", [])
    monkeypatch.setattr(compiled, "_LIBRARY_ONLY", set())
    monkeypatch.setattr(compiled, "KERNEL_MODULES", ())
    compiled.on_warm_up(lambda: calls.append("request path"))
    compiled.on_warm_up(serving=False)(lambda: calls.append("library entry"))
    assert compiled.warm_up(serving=True) == 1 and calls == ["request path"]
    assert compiled.warm_up() == 2 and calls[1:] == ["request path", "library entry"]


def test_the_convex_solver_s_and_the_distance_query_s_own_entries_are_library_only():
    from impactnet.models.compound import convex_contact, warm
    from impactnet.models.distance import bodies, query

    assert convex_contact.warm_up in compiled._LIBRARY_ONLY
    assert query.warm_up in compiled._LIBRARY_ONLY
    assert warm.warm_up not in compiled._LIBRARY_ONLY  # the pipeline: requests call it
    assert bodies._warm_up not in compiled._LIBRARY_ONLY


# A process that loads the frame's broadphase kernels and prints (loaded, compiled) signatures.
_LOAD_FRAME_KERNELS = ("from impactnet.models import compiled; "
                       "from impactnet.models.frame import broadphase; "
                       "broadphase._warm_up(); print(*compiled.signature_counts())")


def _counts(env: dict) -> tuple[int, int]:
    result = subprocess.run([sys.executable, "-c", _LOAD_FRAME_KERNELS], capture_output=True,
                            text=True, timeout=300, env=env, check=True)
    loaded, compiled_count = map(int, result.stdout.split())
    return loaded, compiled_count


@pytest.mark.slow
def test_a_cache_built_ahead_for_a_generic_cpu_loads_elsewhere_without_compiling(tmp_path):
    """An image's build stage compiles for ``NUMBA_CPU_NAME=generic`` (docker/Dockerfile); the
    running container, on another machine and with the cache in another folder, only loads."""
    env = {**os.environ, "NUMBA_CPU_NAME": "generic",
           compiled.CACHE_ENV: str(tmp_path / "built")}
    assert _counts(env)[1] > 0  # the build stage: a cold cache, compiled
    shutil.copytree(tmp_path / "built", tmp_path / "shipped")
    loaded, compiled_count = _counts({**env, compiled.CACHE_ENV: str(tmp_path / "shipped")})
    assert loaded > 0 and compiled_count == 0


def test_the_cache_folder_of_a_kernel_is_its_place_in_the_package_not_its_path():
    from numba.core.caching import CacheImpl

    from impactnet.models.box import kernels

    locator = CacheImpl._locator_classes[0].from_function(kernels.solve_pair.py_func,
                                                          kernels.__file__)
    assert Path(locator.get_cache_path()) == compiled.cache_folder() / "models" / "box"
