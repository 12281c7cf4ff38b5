"""Test helper (not a test module): Debian packages that a suite needs (PostgreSQL, nginx,
Chromium), installed with apt-get where they are missing and we are root.

:func:`apt_install` raises :class:`Unavailable` with the reason where it cannot (not root, no
apt-get, a failing command), which the suites' fixtures turn into a skip with that reason.
"""
from __future__ import annotations

import os
import shutil
import subprocess

#: Seconds allowed for each apt-get command: downloads on a cold machine (Chromium is ~100 MB),
#: and for another apt-get that holds the dpkg lock to finish first.
APT_TIMEOUT_S = 600


class Unavailable(RuntimeError):
    """A program a suite needs cannot be found or installed here (the message says why)."""


def apt_install(package: str, what: str) -> None:
    """``apt-get update`` then ``apt-get install -y package`` (waiting for the dpkg lock);
    ``what`` names the missing program in the :class:`Unavailable` raised where that is not
    possible or fails."""
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        raise Unavailable(f"{what} is not installed and cannot be installed here (needs root "
                          "and apt-get)")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    lock = f"DPkg::Lock::Timeout={APT_TIMEOUT_S}"
    for command in (["apt-get", "update"], ["apt-get", "install", "-y", "-o", lock, package]):
        done = subprocess.run(command, env=env, capture_output=True, text=True,
                              timeout=2 * APT_TIMEOUT_S)
        if done.returncode != 0:
            raise Unavailable(f"{' '.join(command)} failed: {done.stderr.strip()[-400:]}")
