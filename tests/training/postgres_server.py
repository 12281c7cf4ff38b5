"""A throwaway PostgreSQL server on loopback for the sweep tests.

:func:`start` finds ``initdb`` / ``pg_ctl`` (PATH, then ``/usr/lib/postgresql/*/bin``),
installs the ``postgresql`` package with apt-get where they are missing and we are root, and
starts a cluster in a fresh temporary folder on a free port with trust authentication on
127.0.0.1 only. PostgreSQL refuses to run as root, so as root the cluster belongs to the
``postgres`` system user and every server command runs through ``runuser``. :func:`stop` stops
it (immediate mode) and deletes the folder. Anything that prevents a server raises
:class:`Unavailable` with the reason, which the fixture turns into a skip.
"""
from __future__ import annotations

import glob
import os
import shutil
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass

from tests.apt_packages import Unavailable, apt_install

#: Seconds allowed for the server to accept connections after ``pg_ctl start``.
START_TIMEOUT_S = 60
#: The system user that owns the cluster when the tests run as root.
SERVER_USER = "postgres"


@dataclass
class Server:
    """A running throwaway cluster."""

    url: str  # SQLAlchemy URL of its ``sweeps`` database
    folder: str  # temporary folder holding the cluster and its log
    bin_dir: str  # folder of pg_ctl / initdb
    as_user: list[str]  # command prefix that runs a command as the cluster's owner


def _bin_dir() -> str | None:
    found = shutil.which("initdb") and shutil.which("pg_ctl")
    if found:
        return os.path.dirname(os.path.realpath(shutil.which("pg_ctl")))
    candidates = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    return os.path.dirname(candidates[-1]) if candidates else None


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _run(command: list[str], what: str) -> None:
    done = subprocess.run(command, capture_output=True, text=True, timeout=START_TIMEOUT_S)
    if done.returncode != 0:
        raise Unavailable(f"{what} failed: {(done.stderr or done.stdout).strip()[-400:]}")


def start() -> Server:
    """Start a cluster (module docstring); raises Unavailable with the reason."""
    bin_dir = _bin_dir()
    if bin_dir is None:
        apt_install("postgresql", "PostgreSQL (initdb, pg_ctl)")
        bin_dir = _bin_dir()
        if bin_dir is None:
            raise Unavailable("apt-get installed postgresql but no initdb was found")
    as_user = []
    folder = tempfile.mkdtemp(prefix="impactnet-pg-")
    if os.geteuid() == 0:
        if shutil.which("runuser") is None:
            raise Unavailable("running as root without runuser: cannot start PostgreSQL")
        shutil.chown(folder, user=SERVER_USER)
        as_user = ["runuser", "-u", SERVER_USER, "--"]
    data, port = os.path.join(folder, "data"), _free_port()
    _run([*as_user, f"{bin_dir}/initdb", "-D", data, "-A", "trust", "-U", "postgres",
          "--no-sync"], "initdb")
    options = f"-h 127.0.0.1 -p {port} -k {folder} -F"
    _run([*as_user, f"{bin_dir}/pg_ctl", "-D", data, "-l", os.path.join(folder, "log"), "-o",
          options, "-w", "-t", str(START_TIMEOUT_S), "start"], "pg_ctl start")
    server = Server(f"postgresql+psycopg2://postgres@127.0.0.1:{port}/sweeps", folder, bin_dir,
                    as_user)
    _create_database(port)
    return server


def _create_database(port: int) -> None:
    import psycopg2

    deadline = time.monotonic() + START_TIMEOUT_S
    while True:
        try:
            connection = psycopg2.connect(host="127.0.0.1", port=port, user="postgres",
                                          dbname="postgres")
            break
        except psycopg2.OperationalError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)
    connection.autocommit = True
    with connection.cursor() as cursor:
        cursor.execute("CREATE DATABASE sweeps")
    connection.close()


def stop(server: Server) -> None:
    """Stop the cluster at once and delete its folder."""
    subprocess.run([*server.as_user, f"{server.bin_dir}/pg_ctl", "-D",
                    os.path.join(server.folder, "data"), "-m", "immediate", "stop"],
                   capture_output=True, timeout=START_TIMEOUT_S)
    shutil.rmtree(server.folder, ignore_errors=True)
