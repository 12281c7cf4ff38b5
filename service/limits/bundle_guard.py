"""Checks of a bundle folder's files before the bundle reader opens any of them.

:func:`impactnet.models.bundle.format.read_bundle` reads ``manifest.json`` whole and unchecked, and
a reader that opens a FIFO blocks forever (a reload once held its lock and lost its worker thread
that way), while a symlink to ``/dev/zero`` reads without end. So, at startup and on every reload,
before the reader sees the folder (:func:`check_bundle_files`):

* the store pointer (``current``), ``manifest.json`` and every file the manifest lists must be
  regular files (symlinks are followed: a link to a regular file is fine, to a device or a
  FIFO is not), each no larger than its cap below;
* the manifest is parsed here, size-capped, only to learn the listed files;
* the weights' safetensors header length (its first 8 bytes) must be below its cap.

Nothing here blocks: :func:`os.stat` does not open the file, and the only files opened are
regular files known to be small enough. The reload deadline (``reload_timeout_s``) covers a
file swapped for a FIFO between this check and the reader.
"""
from __future__ import annotations

import json
import os
import stat
from pathlib import Path

from impactnet.models.bundle.format import MANIFEST, WEIGHTS, BundleError
from impactnet.models.bundle.store import CURRENT, VERSIONS, check_version_name

#: Largest store pointer in bytes: one version name (at most 200 characters) and a newline.
POINTER_MAX_BYTES = 1024
#: Largest manifest.json in bytes: the shipped one (10 pairs) is 139 KB; a scene of 100 pairs
#: would be ~1.4 MB.
MANIFEST_MAX_BYTES = 16 * 1024 * 1024
#: Largest file a manifest may list, in bytes: the shipped weights are 1.5 MB; the reader
#: holds a file whole in memory while it checks its SHA-256.
FILE_MAX_BYTES = 512 * 1024 * 1024
#: Largest safetensors header in bytes (JSON: name, dtype, shape and offsets of each tensor;
#: ~100 bytes per tensor, a few hundred tensors per bundle).
WEIGHTS_HEADER_MAX_BYTES = 16 * 1024 * 1024
#: Bytes of the little-endian header length that starts a safetensors file.
_HEADER_LENGTH_BYTES = 8


def _regular(path: Path, cap: int, what: str) -> int:
    """Size of ``path``; BundleError unless it is a regular file of at most ``cap`` bytes."""
    try:
        info = os.stat(path)
    except OSError as exc:
        raise BundleError(f"{path}: {what} cannot be read: {exc.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise BundleError(f"{path}: {what} is not a regular file")
    if info.st_size > cap:
        raise BundleError(f"{path}: {what} is {info.st_size} bytes, more than {cap}")
    return info.st_size


def _read_capped(path: Path, cap: int, what: str) -> bytes:
    _regular(path, cap, what)
    with open(path, "rb") as f:
        data = f.read(cap + 1)
    if len(data) > cap:  # grew since the stat
        raise BundleError(f"{path}: {what} is larger than {cap} bytes")
    return data


def store_pointer(path: Path) -> str | None:
    """The version that the store ``path``'s pointer names, read within its cap (a FIFO or a
    device there is refused, never opened); None where ``path`` has no pointer (a plain
    bundle folder, or nothing at all). BundleError for a bad pointer."""
    pointer = path / CURRENT
    if not os.path.lexists(pointer):
        return None
    name = _read_capped(pointer, POINTER_MAX_BYTES, "the store pointer")
    try:
        return check_version_name(name.decode("utf-8").strip())
    except UnicodeDecodeError:
        raise BundleError(f"{pointer}: not a version name") from None


def _bundle_folder(path: Path) -> Path:
    """The folder the reader will read: a store's current version, else ``path``."""
    version = store_pointer(path)
    return path if version is None else path / VERSIONS / version


def check_bundle_files(path: Path) -> Path:
    """The folder to read for ``path`` (a store's current version, named by the pointer read
    once here, else ``path``); raise :class:`impactnet.models.bundle.format.BundleError` unless
    its files are regular files within their caps (module docstring). A missing folder or
    manifest is left to the reader."""
    if not path.is_dir():
        return path
    folder = _bundle_folder(path)
    manifest_path = folder / MANIFEST
    if not os.path.lexists(manifest_path):
        return folder  # the reader reports a missing manifest
    try:
        manifest = json.loads(_read_capped(manifest_path, MANIFEST_MAX_BYTES, "the manifest"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BundleError(f"{manifest_path}: invalid JSON: {exc}") from None
    files = manifest.get("files") if isinstance(manifest, dict) else None
    for name in files if isinstance(files, dict) else ():
        if os.path.lexists(folder / str(name)):
            _regular(folder / str(name), FILE_MAX_BYTES, f"bundle file {name!r}")
    weights = folder / WEIGHTS
    if not os.path.lexists(weights):
        return folder
    if _regular(weights, FILE_MAX_BYTES, "the weights") >= _HEADER_LENGTH_BYTES:
        with open(weights, "rb") as f:
            length = int.from_bytes(f.read(_HEADER_LENGTH_BYTES), "little")
        if length > WEIGHTS_HEADER_MAX_BYTES:
            raise BundleError(f"{weights}: safetensors header of {length} bytes, more than "
                              f"{WEIGHTS_HEADER_MAX_BYTES}")
    return folder
