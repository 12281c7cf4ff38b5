"""Atomic writes of bundle folders: fsynced files, fsynced folders, and a folder replaced by
two renames (the old one moved aside first), so that a reader never finds half a bundle."""
from __future__ import annotations

import os
import shutil
import uuid
from pathlib import Path

__all__ = ["fsync_dir", "replace_folder", "write_file"]


def write_file(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` and fsync it."""
    with open(path, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())


def fsync_dir(path: Path) -> None:
    """Fsync a folder, so that the renames and new files in it are on disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def replace_folder(new: Path, folder: Path) -> None:
    """Rename ``new`` to ``folder``, moving an existing ``folder`` away first."""
    if not folder.exists():
        os.rename(new, folder)
        return
    old = folder.parent / f".{folder.name}.old-{uuid.uuid4().hex[:12]}"
    os.rename(folder, old)
    try:
        os.rename(new, folder)
    except BaseException:
        os.rename(old, folder)
        raise
    shutil.rmtree(old, ignore_errors=True)
