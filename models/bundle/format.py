"""Bundles on disk as plain data (docs/learned_predictors.md, "Bundle folder").

A bundle is a folder holding exactly ``manifest.json`` and the files the manifest lists in
``files`` (``weights.safetensors``). Reading (:func:`read_bundle_data`) verifies, in this order:
that the folder holds no other file and misses none, every file's size and SHA-256, the
manifest's format and version (:func:`impactnet.models.bundle.manifest.check_header`) and that
every tensor is float32; it returns the manifest and the tensors (:class:`BundleData`). Tensors
are read with ``safetensors.numpy`` from the same bytes that were hashed; nothing is pickled.

Writing (:func:`write_bundle_data`) runs the same checks first, and the caller's check of the
content (the learned side builds its models from it,
:func:`impactnet.models.learned.bundle_loader.write_bundle`), so an unreadable bundle is never
written; then it writes into a temporary sibling folder (``.<name>.tmp-<random>``), fsyncs it,
and renames it into place. An existing bundle is first renamed away (``.<name>.old-<random>``)
and deleted after the new one is in place: a crash before the renames leaves the old bundle
untouched (and a temporary folder to delete); a crash between the two renames leaves the old
bundle complete under its ``.old`` name, never half a bundle at ``path``.

This module knows tensors and manifests only; what the MLPs and pairs of a manifest mean is
:mod:`impactnet.models.learned.bundle_loader`'s business.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import safetensors.numpy

from impactnet.models.bundle.atomic import fsync_dir, replace_folder, write_file
from impactnet.models.bundle.manifest import (
    FORMAT,
    FORMAT_VERSION,
    SERVE_EXACT_ONLY,
    SERVE_LEARNED,
    BundleError,
    check_header,
    check_tensors,
    decision_of,
    finite_numbers,
)

MANIFEST = "manifest.json"
WEIGHTS = "weights.safetensors"

__all__ = ["FORMAT", "FORMAT_VERSION", "MANIFEST", "SERVE_EXACT_ONLY", "SERVE_LEARNED", "WEIGHTS",
           "BundleData", "BundleError", "bundle_data", "decision_of", "finite_numbers",
           "fsync_dir", "read_bundle_data", "write_bundle_data", "write_file"]


@dataclass(frozen=True)
class BundleData:
    """A bundle's content as plain data, its header and dtypes checked."""

    manifest: dict  # the parsed manifest.json (JSON types only)
    tensors: dict[str, np.ndarray]  # name -> float32 array, as stored
    path: Path | None = None  # the folder it was read from, if any

    @property
    def version(self) -> str:
        """The manifest's ``version``, ``"unversioned"`` where it has none."""
        return str(self.manifest.get("version", "unversioned"))


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _parse_json(data: bytes):
    def refuse(constant):
        raise BundleError(f"{MANIFEST}: {constant} is not JSON")
    try:
        return json.loads(data.decode("utf-8"), parse_constant=refuse)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BundleError(f"{MANIFEST}: invalid JSON: {exc}") from None


def _checked(manifest, tensors: dict[str, np.ndarray], path: Path | None = None) -> BundleData:
    check_header(manifest)
    check_tensors(tensors)
    return BundleData(manifest, tensors, path)


def bundle_data(manifest: dict, tensors: dict[str, np.ndarray]) -> BundleData:
    """The content :func:`write_bundle_data` would write, without files: a deep, JSON-clean
    copy of ``manifest`` (``format`` and ``format_version`` set if missing) and the tensors
    cast to float32, C order; BundleError where the header is not this format's."""
    manifest = json.loads(json.dumps(manifest, allow_nan=False))
    manifest.setdefault("format", FORMAT)
    manifest.setdefault("format_version", FORMAT_VERSION)
    arrays = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in tensors.items()}
    return _checked(manifest, arrays)


def _file_contents(folder: Path, manifest) -> dict[str, bytes]:
    """Name -> bytes of every file the manifest lists, each checked against its size and
    SHA-256, the folder holding no other file."""
    files = manifest.get("files") if isinstance(manifest, dict) else None
    if not isinstance(files, dict) or WEIGHTS not in files:
        raise BundleError(f"{folder}: the manifest must list {WEIGHTS} in 'files'")
    present = set(os.listdir(folder))
    if present != {MANIFEST, *files}:
        raise BundleError(f"{folder}: files do not match the manifest (extra "
                          f"{sorted(present - {MANIFEST, *files})}, missing "
                          f"{sorted({MANIFEST, *files} - present)})")
    contents = {}
    for name, entry in files.items():
        data = (folder / name).read_bytes() if (folder / name).is_file() else None
        if (data is None or not isinstance(entry, dict) or len(data) != entry.get("bytes")
                or _sha256(data) != entry.get("sha256")):
            raise BundleError(f"{folder / name}: size or SHA-256 differs from the manifest")
        contents[name] = data
    return contents


def read_bundle_data(path) -> BundleData:
    """Read and verify a bundle folder's files, manifest header and tensors (module
    docstring); raises BundleError."""
    folder = Path(path)
    if not folder.is_dir():
        raise BundleError(f"{folder}: no such bundle folder")
    if not (folder / MANIFEST).is_file():
        raise BundleError(f"{folder}: no {MANIFEST}")
    manifest = _parse_json((folder / MANIFEST).read_bytes())
    contents = _file_contents(folder, manifest)
    try:
        tensors = safetensors.numpy.load(contents[WEIGHTS])
    except Exception as exc:  # the Rust SafetensorError derives from Exception only
        raise BundleError(f"{folder / WEIGHTS}: not a safetensors file: {exc}") from None
    return _checked(manifest, tensors, folder)


def write_bundle_data(path, manifest: dict, tensors: dict[str, np.ndarray],
                      check: Callable[[BundleData], object] | None = None) -> Path:
    """Write a bundle folder atomically (see the module docstring).

    Parameters
    ----------
    path : str or PathLike
        The bundle folder; an existing bundle there is replaced.
    manifest : dict
        The manifest without ``files`` (filled here); ``format`` and ``format_version`` are
        set if missing.
    tensors : dict of str -> ndarray
        The tensors (cast to float32, C order).
    check : callable, optional
        Called with the content as it will read back (manifest with ``files``, tensors from
        the bytes to write) before anything is written; raises BundleError to refuse it.

    Returns
    -------
    Path
        ``path``. Raises BundleError (nothing written) when the content would not read back.
    """
    folder = Path(path)
    content = bundle_data(manifest, tensors)
    data = safetensors.numpy.save(content.tensors)
    manifest = content.manifest
    manifest["files"] = {WEIGHTS: {"sha256": _sha256(data), "bytes": len(data)}}
    written = _checked(manifest, safetensors.numpy.load(data))
    if check is not None:
        check(written)
    text = json.dumps(manifest, indent=2, sort_keys=True, allow_nan=False) + "\n"
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = folder.parent / f".{folder.name}.tmp-{uuid.uuid4().hex[:12]}"
    tmp.mkdir()
    try:
        write_file(tmp / WEIGHTS, data)
        write_file(tmp / MANIFEST, text.encode("utf-8"))
        fsync_dir(tmp)
        replace_folder(tmp, folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    fsync_dir(folder.parent)
    return folder
