"""Fixtures of the training tests: a throwaway PostgreSQL server for the sweep tests."""
from __future__ import annotations

import os

import pytest

from tests.conftest import POSTGRES_URL_ENV


@pytest.fixture(scope="session")
def postgres_server_url():
    """SQLAlchemy URL of a PostgreSQL database for sweeps.

    ``IMPACTNET_TEST_POSTGRES_URL`` where set (an existing server); else a throwaway cluster on
    loopback (:mod:`tests.training.postgres_server`), installed with apt-get if needed. Skipped,
    with the reason, only where no server can be started.
    """
    url = os.environ.get(POSTGRES_URL_ENV)
    if url:
        yield url
        return
    from tests.training import postgres_server

    try:
        server = postgres_server.start()
    except postgres_server.Unavailable as exc:
        pytest.skip(f"PostgreSQL cannot be started here: {exc}")
    try:
        yield server.url
    finally:
        postgres_server.stop(server)
