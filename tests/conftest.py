"""Shared pytest configuration.

Markers (declared in pyproject.toml):
- ``slow``: long fuzz / load tests. ``make test`` (and CI) runs them; ``make test-fast`` skips
  them with ``-m "not slow"``.

PostgreSQL: the sweep tests start a throwaway server themselves
(``tests/training/conftest.py::postgres_server_url``), or use the one that
``IMPACTNET_TEST_POSTGRES_URL`` names.

Hypothesis: the ``impactnet`` profile (default) has no per-example deadline, since NumPy calls
vary in time with the machine's load; ``HYPOTHESIS_PROFILE=ci`` additionally derandomises.
"""
from __future__ import annotations

import os

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
