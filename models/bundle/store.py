"""Bundle stores: versioned bundles in one folder, and a ``current`` pointer to the served one.

Layout of a store folder (what ``impactnet train`` and ``impactnet sweep`` write)::

    <store>/current               text file: the name of the current version folder, one line
    <store>/versions/<version>/   a bundle (impactnet.models.bundle.format: manifest.json,
    weights.safetensors)
    <store>/rejected/<version>/   bundles that failed their validation gate (kept to inspect)
    <store>/.cache/               per-pair training cache of the training side (not a bundle)

``.cache/`` and ``rejected/`` are git- and Docker-ignored: a committed store is ``current`` and
``versions/``.

The pointer is a small text file, not a symlink, so that a store survives git, wheels, zip
files and Docker ``COPY`` unchanged on every platform. It moves atomically
(:func:`set_current`: write a temporary file, fsync, ``os.replace``, fsync the folder), so a
reader sees the old version or the new one, never a mix; version folders are written
atomically by :func:`impactnet.models.bundle.format.write_bundle_data` before the pointer names
them.

:func:`resolve_bundle` is what readers call: a store resolves to its current version, a plain
bundle folder (one with ``manifest.json`` and no pointer) to itself, so both keep working
wherever a bundle path is accepted.
"""
from __future__ import annotations

import os
import re
import shutil
import uuid
from pathlib import Path

from impactnet.models.bundle.format import MANIFEST, BundleError, fsync_dir, write_file

#: The pointer file of a store.
CURRENT = "current"
#: Sub-folder of the accepted versions.
VERSIONS = "versions"
#: Sub-folder of the versions that failed their validation gate.
REJECTED = "rejected"
#: A version folder name: letters, digits, ``.``, ``_``, ``-`` (no path separators, so a pointer
#: can never point outside its store).
_VERSION_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,199}$")


def is_store(path) -> bool:
    """True where ``path`` is a store folder (it has a ``current`` pointer file)."""
    return (Path(path) / CURRENT).is_file()


def check_version_name(name: str) -> str:
    """``name`` if it is a valid version folder name; raises BundleError otherwise."""
    if not _VERSION_NAME.match(name):
        raise BundleError(f"invalid bundle version name {name!r}")
    return name


def current_version(store) -> str | None:
    """The version named by the store's pointer, None where there is no pointer."""
    pointer = Path(store) / CURRENT
    if not pointer.is_file():
        return None
    return check_version_name(pointer.read_text(encoding="utf-8").strip())


def resolve_bundle(path) -> Path:
    """The bundle folder to read for ``path``.

    A store (a folder with a ``current`` pointer) resolves to ``versions/<current>``; anything
    else is returned unchanged (a plain bundle folder, or a missing path that the reader then
    reports).

    Raises
    ------
    impactnet.models.bundle.format.BundleError
        The pointer is malformed or names a version that does not exist.
    """
    folder = Path(path)
    version = current_version(folder)
    if version is None:
        return folder
    target = folder / VERSIONS / version
    if not target.is_dir():
        raise BundleError(f"{folder}: '{CURRENT}' names version {version!r} but "
                          f"{target} does not exist")
    return target


def set_current(store, version: str) -> None:
    """Point the store at ``version`` (an existing ``versions/<version>`` folder), atomically."""
    folder = Path(store)
    if not (folder / VERSIONS / check_version_name(version)).is_dir():
        raise BundleError(f"{folder}: no version folder {version!r} to point at")
    tmp = folder / f".{CURRENT}.tmp-{uuid.uuid4().hex[:12]}"
    try:
        write_file(tmp, f"{version}\n".encode())
        os.replace(tmp, folder / CURRENT)
    finally:
        tmp.unlink(missing_ok=True)
    fsync_dir(folder)


def list_versions(store, kind: str = VERSIONS) -> list[str]:
    """Version folder names under ``kind`` (``versions`` or ``rejected``), oldest first.

    Age is the folder's modification time (names break ties), so versions sort by when they were
    written even where their names do not sort by time.
    """
    root = Path(store) / kind
    if not root.is_dir():
        return []
    entries = [p for p in root.iterdir() if p.is_dir() and _VERSION_NAME.match(p.name)]
    return [p.name for p in sorted(entries, key=lambda p: (p.stat().st_mtime, p.name))]


def prune(store, keep: int, kind: str = VERSIONS) -> list[str]:
    """Delete all but the newest ``keep`` folders under ``kind``; the current one always stays.

    Returns the deleted version names. ``keep`` < 1 is refused (the current version and the one
    before it are what a rollback needs).
    """
    if keep < 1:
        raise ValueError(f"keep must be >= 1, got {keep}")
    current = current_version(store)
    names = list_versions(store, kind)
    doomed = [n for n in names[:max(0, len(names) - keep)] if n != current]
    for name in doomed:
        shutil.rmtree(Path(store) / kind / name, ignore_errors=True)
    return doomed


def adopt_plain_bundle(folder, version: str) -> bool:
    """Turn a plain bundle folder into a store; False where it is not a plain bundle.

    The store is built beside the folder (``.<name>.adopt-<random>``: a copy of the bundle's
    files under ``versions/<version>/`` and the pointer), then swapped in by two renames: the
    bundle folder aside, the store into its place, and the old folder deleted. Until the first
    rename readers find the plain bundle; after the second, the store; a crash between the two
    leaves the complete bundle under its ``.old`` name, never half a store.
    """
    folder = Path(folder)
    if is_store(folder) or not (folder / MANIFEST).is_file():
        return False
    staging = folder.parent / f".{folder.name}.adopt-{uuid.uuid4().hex[:12]}"
    target = staging / VERSIONS / check_version_name(version)
    try:
        target.mkdir(parents=True)
        for entry in folder.iterdir():
            if entry.is_file():
                shutil.copy2(entry, target / entry.name)
        fsync_dir(target)
        set_current(staging, version)
        old = folder.parent / f".{folder.name}.old-{uuid.uuid4().hex[:12]}"
        os.rename(folder, old)
        os.rename(staging, folder)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    fsync_dir(folder.parent)
    shutil.rmtree(old, ignore_errors=True)
    return True
