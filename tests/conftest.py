"""Shared pytest configuration.

Markers (declared in pyproject.toml):
- ``slow``: long fuzz / load tests. ``make test`` (and CI) runs them; ``make test-fast`` skips
  them with ``-m "not slow"``.
- ``serial``: every test under :data:`SERIAL_PATHS` (marked here, at collection). ``make test``
  runs the other tests in parallel workers (pytest-xdist), then these in one process, alone.

PostgreSQL: the sweep tests start a throwaway server themselves
(``tests/training/conftest.py::postgres_server_url``), or use the one that
``IMPACTNET_TEST_POSTGRES_URL`` names.

Hypothesis: the ``impactnet`` profile (default) has no per-example deadline, since NumPy calls
vary in time with the machine's load; ``HYPOTHESIS_PROFILE=ci`` additionally derandomises.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

#: Tests (paths under tests/: folders end with "/") that run in one process, alone, after the
#: parallel workers: those that hold real servers to wall-clock figures (/healthz's p99 under
#: hostile load, the memory budget, deadlines and drains of a fleet), so that a neighbour's load
#: never moves their figures.
SERIAL_PATHS = ("service/hostile/", "fleet/")

#: An existing PostgreSQL server for the sweep tests (else they start their own).
POSTGRES_URL_ENV = "IMPACTNET_TEST_POSTGRES_URL"

try:
    from hypothesis import settings as _hypothesis_settings
except ImportError:  # the dev extra is not installed: tests that need hypothesis fail by name
    _hypothesis_settings = None

if _hypothesis_settings is not None:
    _hypothesis_settings.register_profile("impactnet", deadline=None, print_blob=True)
    _hypothesis_settings.register_profile(
        "ci", parent=_hypothesis_settings.get_profile("impactnet"), derandomize=True
    )
    _hypothesis_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "impactnet"))


@pytest.hookimpl(tryfirst=True)  # before ``-m`` selects by marker
def pytest_collection_modifyitems(config, items):
    """Mark the tests of :data:`SERIAL_PATHS` ``serial``; refuse to run when tests outside
    them share a node id: parallel workers report such items passed without running them (the
    items one schemathesis function makes, one per API operation, did: test_schemathesis.py
    now has a function per operation)."""
    root = Path(__file__).resolve().parent
    seen, shared = set(), set()
    for item in items:
        path = Path(item.path).resolve().relative_to(root).as_posix()
        if any(path.startswith(p) for p in SERIAL_PATHS):
            item.add_marker(pytest.mark.serial)
        elif item.nodeid in seen:
            shared.add(item.nodeid)
        seen.add(item.nodeid)
    if shared:
        raise pytest.UsageError(f"tests share a node id, so parallel workers cannot run them: "
                                f"{sorted(shared)[:5]}; add them to SERIAL_PATHS")
