"""Bundle stores (impactnet.models.bundle.store): the `current` pointer, resolution by every reader,
pruning and adoption of a plain bundle folder."""
from __future__ import annotations

import os
import threading
import time

import pytest

from impactnet.models import load_predictor
from impactnet.models.bundle.format import BundleError
from impactnet.models.bundle.store import (
    CURRENT,
    VERSIONS,
    adopt_plain_bundle,
    current_version,
    is_store,
    list_versions,
    prune,
    resolve_bundle,
    set_current,
)
from impactnet.models.learned.bundle_loader import read_bundle
from tests.models.learned.learned_fixtures import write_test_bundle


def _store(tmp_path, versions=("v1", "v2")):
    store = tmp_path / "store"
    for i, name in enumerate(versions):
        write_test_bundle(store / VERSIONS / name)
        stamp = time.time() - 100 + i  # oldest first, whatever the file system's resolution
        os.utime(store / VERSIONS / name, (stamp, stamp))
    return store


def test_pointer_moves_atomically_and_readers_follow_it(tmp_path):
    store = _store(tmp_path)
    assert not is_store(store) and resolve_bundle(store) == store
    set_current(store, "v1")
    assert is_store(store) and current_version(store) == "v1"
    assert resolve_bundle(store) == store / VERSIONS / "v1"
    set_current(store, "v2")
    assert (store / CURRENT).read_text() == "v2\n"
    assert sorted(p.name for p in store.iterdir()) == [CURRENT, VERSIONS]  # no temporary file
    assert load_predictor("committee", store) is not None  # a store loads like a bundle


def test_plain_bundle_folders_keep_resolving_to_themselves(tmp_path):
    plain = write_test_bundle(tmp_path / "plain")
    assert resolve_bundle(plain) == plain
    assert read_bundle(resolve_bundle(plain)).manifest["pairs"]


@pytest.mark.parametrize("pointer", ["missing-version\n", "../escape\n", "\n"])
def test_a_bad_pointer_is_refused_by_name(tmp_path, pointer):
    store = _store(tmp_path)
    (store / CURRENT).write_text(pointer)
    with pytest.raises(BundleError):
        resolve_bundle(store)


def test_pointing_at_a_missing_version_is_refused(tmp_path):
    store = _store(tmp_path)
    with pytest.raises(BundleError, match="no version folder"):
        set_current(store, "v9")
    assert current_version(store) is None


def test_prune_keeps_the_newest_and_always_the_current(tmp_path):
    store = _store(tmp_path, ("v1", "v2", "v3", "v4"))
    set_current(store, "v1")
    assert prune(store, keep=2) == ["v2"]
    assert list_versions(store) == ["v1", "v3", "v4"]
    with pytest.raises(ValueError):
        prune(store, keep=0)


def test_a_plain_bundle_folder_is_adopted_as_the_first_version(tmp_path):
    folder = write_test_bundle(tmp_path / "bundle")
    version = read_bundle(folder).version
    assert adopt_plain_bundle(folder, "first")
    assert current_version(folder) == "first"
    assert read_bundle(resolve_bundle(folder)).version == version
    assert not adopt_plain_bundle(folder, "again")  # already a store


#: Versions published while the reader polls: enough writes for the loop to interleave with.
PUBLISHES = 12
#: Longest the tight loop may poll, in seconds (it stops earlier, once the publisher is done).
POLL_BOUND_S = 20.0


def test_a_reader_polling_in_a_tight_loop_never_sees_a_partial_version(tmp_path):
    """The publisher writes each version as a training job does (``write_bundle`` into a
    hidden temporary folder renamed into ``versions/``, then ``set_current``) while a reader
    resolves and reads the store as fast as it can: every read is a complete, verified
    version whose manifest names its folder, and the versions read never go back."""
    from impactnet.models.learned.bundle_loader import write_bundle
    from tests.models.learned.learned_fixtures import bundle_content

    manifest, tensors = bundle_content()
    store = tmp_path / "store"
    write_bundle(store / VERSIONS / "p00", manifest | {"version": "p00"}, tensors)
    set_current(store, "p00")
    writing, done, errors = threading.Event(), threading.Event(), []

    def publisher() -> None:
        try:
            for i in range(1, PUBLISHES + 1):
                name = f"p{i:02d}"
                writing.set()
                write_bundle(store / VERSIONS / name, manifest | {"version": name}, tensors)
                writing.clear()
                set_current(store, name)
        except BaseException as exc:  # noqa: BLE001 - reported by the test
            errors.append(exc)
        finally:
            done.set()

    thread = threading.Thread(target=publisher)
    thread.start()
    seen, during_writes = [], 0
    deadline = time.monotonic() + POLL_BOUND_S
    while not done.is_set() and time.monotonic() < deadline:
        during_writes += writing.is_set()
        folder = resolve_bundle(store)
        bundle = read_bundle(folder)  # raises on a missing file or a checksum that differs
        assert bundle.version == folder.name and folder.parent.name == VERSIONS
        seen.append(folder.name)
    thread.join(POLL_BOUND_S)
    assert not errors and done.is_set()
    assert seen == sorted(seen) and len(set(seen)) > 1  # forward only, several versions
    assert during_writes > 0  # the loop really polled while versions were being written
    assert current_version(store) == f"p{PUBLISHES:02d}"
    assert not [p for p in (store / VERSIONS).iterdir() if p.name.startswith(".")]
