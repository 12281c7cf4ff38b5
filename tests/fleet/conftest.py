"""Fixtures of the fleet tests: Debian's nginx (installed with apt-get where missing)."""
from __future__ import annotations

import pytest

from tests.fleet import helpers


@pytest.fixture(scope="session")
def nginx() -> str:
    """The nginx binary; the test is skipped, with the reason, where none can be had."""
    try:
        return helpers.nginx_binary()
    except helpers.Unavailable as exc:
        pytest.skip(f"nginx cannot be had here: {exc}")
