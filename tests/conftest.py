"""Shared pytest configuration.

Markers (declared in pyproject.toml):
- ``slow``: long fuzz / load tests. ``make test`` (and CI) runs them; ``make test-fast`` skips
  them with ``-m "not slow"``.
- ``postgres``: needs a PostgreSQL server; skipped unless ``IMPACTNET_TEST_POSTGRES_URL`` names
  one (the URL is available to tests through the ``postgres_url`` fixture).

Hypothesis: the ``impactnet`` profile (default) has no per-example deadline, since NumPy calls
vary in time with the machine's load; ``HYPOTHESIS_PROFILE=ci`` additionally derandomises.
"""
from __future__ import annotations

import os

import pytest

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


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get(POSTGRES_URL_ENV):
        return
    skip = pytest.mark.skip(reason=f"needs PostgreSQL: set {POSTGRES_URL_ENV}")
    for item in items:
        if "postgres" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def postgres_url() -> str:
    """The PostgreSQL URL of the test server (tests marked ``postgres`` only run when it is set)."""
    url = os.environ.get(POSTGRES_URL_ENV)
    if not url:
        pytest.skip(f"needs PostgreSQL: set {POSTGRES_URL_ENV}")
    return url
