"""Contact datasets on disk: a pickle-free ``.npz`` beside a JSON manifest, byte-reproducible.

Layout of a dataset called ``NAME`` (written by
:func:`impactnet.training.data.datagen.generate_dataset`)::

    NAME.npz   one ``.npy`` entry per column (N rows each), zip entries stored (no
               compression), in a fixed order, every entry dated 1980-01-01 00:00:00, so the
               same arrays always give the same bytes (``np.savez`` stamps the current time)
    NAME.json  the manifest: seed, generator version, scene name and hash, config, columns,
               per-pair sizes and counts (contact types, regions, orientation families,
               separated rows) and the SHA-256 of NAME.npz

:func:`load_dataset` checks the SHA-256, the columns and every count before it returns, and
reads with ``allow_pickle=False``.

Bytes are reproducible for the same seed, config and NumPy version (the manifest records the
version: NumPy does not promise identical random streams across releases).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from impactnet.models.contacts import CONTACT_TYPES

#: ``format`` field of every manifest.
FORMAT = "impactnet-contact-dataset"
#: Timestamp of every zip entry: the earliest a zip can hold, so that bytes never depend on
#: the clock.
ZIP_DATE_TIME = (1980, 1, 1, 0, 0, 0)
#: Entries at least this large (bytes) get zip64 headers (zip's 32-bit limit is 4 GiB; the
#: margin covers the .npy header). Fixed by the size alone, so the bytes stay deterministic.
ZIP64_THRESHOLD = 2**31
#: Block size (bytes) for hashing files.
_HASH_BLOCK = 1 << 22
#: ``create_system`` of the zip entries (3 = Unix), fixed so Windows writes the same bytes.
_ZIP_UNIX = 3
#: Features are -1..25; a region code is ``(type * 27 + fa + 1) * 27 + fb + 1``.
_FEATURE_SPAN = 27


class DatasetError(ValueError):
    """A dataset that does not match its manifest (tampered, truncated or mismatched)."""


def write_npz(path: str | os.PathLike, arrays: Mapping[str, np.ndarray]) -> str:
    """Write ``arrays`` as an uncompressed, deterministic ``.npz``; returns its SHA-256 (hex).

    Entries are written in the mapping's order. Object arrays are refused (no pickle). The
    file is written beside ``path`` and renamed into place, so a crash leaves no half file.
    """
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    with open(tmp, "wb") as handle, zipfile.ZipFile(handle, "w", zipfile.ZIP_STORED) as archive:
        for key, value in arrays.items():
            array = np.ascontiguousarray(value)
            if array.dtype.hasobject:
                raise TypeError(f"column {key!r} has dtype object; datasets hold no pickle")
            info = zipfile.ZipInfo(f"{key}.npy", date_time=ZIP_DATE_TIME)
            info.compress_type = zipfile.ZIP_STORED
            info.create_system = _ZIP_UNIX
            info.external_attr = 0o644 << 16
            with archive.open(info, "w", force_zip64=array.nbytes >= ZIP64_THRESHOLD) as entry:
                np.lib.format.write_array(entry, array, allow_pickle=False)
    os.replace(tmp, path)
    return file_sha256(path)


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 (hex) of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(_HASH_BLOCK):
            digest.update(block)
    return digest.hexdigest()


_INNER_LIST = re.compile(r"\[[^\[\]{}]*\]")


def _one_line(match: re.Match) -> str:
    """An innermost JSON list re-dumped on one line (left as is if it does not parse)."""
    try:
        return json.dumps(json.loads(match.group(0)), allow_nan=False)
    except ValueError:
        return match.group(0)


def dumps_manifest(manifest: Mapping) -> str:
    """JSON text of a manifest: indented, innermost lists on one line, newline-terminated."""
    return _INNER_LIST.sub(_one_line, json.dumps(manifest, indent=2, allow_nan=False)) + "\n"


def summarize(labels: Mapping[str, np.ndarray], families: tuple[str, ...]) -> dict:
    """Counts of one block of rows.

    Parameters
    ----------
    labels : mapping with ``contact_type_code``, ``feature_a``, ``feature_b`` (int8, (n,)),
        ``family`` (int8, (n,)), ``colliding`` (bool, (n,)) and ``push_depth`` (float, (n,))
    families : names of the family ids

    Returns
    -------
    dict
        ``rows``; ``contact_types`` {name: count} over all of CONTACT_TYPES; ``regions``, a
        list of ``[contact_type, feature_a, feature_b, count]`` sorted by code (a region is a
        discontinuity-free (type, features) class); ``families`` {name: count};
        ``separated`` (rows labelled not colliding) and ``pushed_out`` (push_depth < 0).
    """
    code = labels["contact_type_code"].astype(np.int64)
    region = ((code * _FEATURE_SPAN + labels["feature_a"] + 1) * _FEATURE_SPAN
              + labels["feature_b"] + 1)
    keys, counts = np.unique(region, return_counts=True)
    type_counts = np.bincount(code, minlength=len(CONTACT_TYPES))
    family_counts = np.bincount(labels["family"].astype(np.int64), minlength=len(families))
    return {
        "rows": int(code.shape[0]),
        "contact_types": {name: int(c) for name, c in zip(CONTACT_TYPES, type_counts,
                                                          strict=True)},
        "regions": [[CONTACT_TYPES[k // _FEATURE_SPAN**2], int(k // _FEATURE_SPAN
                     % _FEATURE_SPAN) - 1, int(k % _FEATURE_SPAN) - 1, int(c)]
                    for k, c in zip(keys.tolist(), counts.tolist(), strict=True)],
        "families": {name: int(c) for name, c in zip(families, family_counts, strict=True)},
        "separated": int((~labels["colliding"]).sum()),
        "pushed_out": int((labels["push_depth"] < 0).sum()),
    }


def column_specs(arrays: Mapping[str, np.ndarray]) -> dict:
    """``{name: {"dtype": "<f8", "shape": [n, 3]}}`` in the arrays' order."""
    return {k: {"dtype": v.dtype.str, "shape": list(v.shape)} for k, v in arrays.items()}


def dataset_paths(path: str | os.PathLike) -> tuple[Path, Path]:
    """(npz, manifest) paths of a dataset given by either file or by the common stem."""
    path = Path(path)
    stem = path.with_suffix("") if path.suffix in (".npz", ".json") else path
    return stem.with_name(stem.name + ".npz"), stem.with_name(stem.name + ".json")


def load_dataset(path: str | os.PathLike) -> tuple[dict[str, np.ndarray], dict]:
    """Read a dataset and verify it against its manifest.

    Parameters
    ----------
    path : str or PathLike
        ``NAME.npz``, ``NAME.json`` or ``NAME``.

    Returns
    -------
    arrays : dict of ndarray
        Every column (see the manifest's ``columns``), read with ``allow_pickle=False``.
    manifest : dict

    Raises
    ------
    DatasetError
        Missing file, wrong format, SHA-256 mismatch, columns or counts that differ from the
        manifest.
    """
    npz_path, manifest_path = dataset_paths(path)
    for file in (npz_path, manifest_path):
        if not file.is_file():
            raise DatasetError(f"{file}: no such file")
    try:
        manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        recorded = manifest["npz"]["sha256"] if manifest.get("format") == FORMAT else None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise DatasetError(f"{manifest_path}: unreadable manifest ({exc})") from exc
    if recorded is None:
        raise DatasetError(f"{manifest_path}: not an impactnet dataset manifest")
    digest = file_sha256(npz_path)
    if digest != recorded:
        raise DatasetError(f"{npz_path}: SHA-256 {digest} differs from the manifest's "
                           f"{recorded} (file changed or truncated)")
    with np.load(npz_path, allow_pickle=False) as archive:
        arrays = {key: archive[key] for key in archive.files}
    try:
        _verify(arrays, manifest, npz_path)
    except (KeyError, TypeError) as exc:
        raise DatasetError(f"{manifest_path}: manifest lacks a field ({exc})") from exc
    return arrays, manifest


def _verify(arrays: dict, manifest: dict, source: Path) -> None:
    """Columns and per-pair counts of ``arrays`` equal the manifest's; else DatasetError."""
    if column_specs(arrays) != manifest["columns"]:
        raise DatasetError(f"{source}: columns differ from the manifest")
    families = tuple(manifest["families"])
    start = 0
    for pair in manifest["pairs"]:
        block = slice(start, start + pair["rows"])
        if not (arrays["pair_index"][block] == pair["index"]).all():
            raise DatasetError(f"{source}: pair_index differs from the manifest for "
                               f"pair {pair['index']}")
        counts = summarize({k: v[block] for k, v in arrays.items()}, families)
        if any(counts[k] != pair[k] for k in counts):
            raise DatasetError(f"{source}: counts of pair {pair['index']} ({pair['a']}/"
                               f"{pair['b']}) differ from the manifest")
        start = block.stop
    if start != manifest["rows"] or len(arrays["pair_index"]) != start:
        raise DatasetError(f"{source}: {len(arrays['pair_index'])} rows, manifest says "
                           f"{manifest['rows']}")
