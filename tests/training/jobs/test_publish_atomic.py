"""Publishing cannot half-publish: while `impactnet train --out STORE` and `impactnet sweep
--show --out STORE` publish, a reader that polls the store in a tight loop (as a replica that
follows it does, only faster) only ever reads complete, verified versions, and `current`
moves forward to the new one."""
from __future__ import annotations

import threading
import time

import pytest

from impactnet.cli import main
from impactnet.models.bundle.store import VERSIONS, current_version, resolve_bundle
from impactnet.models.learned.bundle_loader import read_bundle
from tests.training.sweep.test_sweep import loose_scene, sweep_args

#: Longest a poller may run, in seconds: a bound on the tight loop if a publish hangs.
POLL_BOUND_S = 600.0
#: Reads of the new version the poller must make after the publisher is done, and how long
#: the test waits for them (s): on a loaded shared machine a fixed sleep gave only 2 reads.
READS_AFTER, READS_WAIT_S = 10, 30.0


class TightPoller:
    """A thread that resolves and reads the store as fast as it can until stopped: each read
    must verify (files, sizes, SHA-256) and name its own folder; ``seen`` lists the versions
    read, in order; ``errors`` what went wrong."""

    def __init__(self, store) -> None:
        self.store, self.seen, self.errors, self.reads = store, [], [], 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        deadline = time.monotonic() + POLL_BOUND_S
        while not self._stop.is_set() and time.monotonic() < deadline:
            if current_version(self.store) is None:
                continue  # nothing published yet (or a plain folder being adopted)
            try:
                folder = resolve_bundle(self.store)
                bundle = read_bundle(folder)
                assert bundle.version == folder.name and folder.parent.name == VERSIONS
            except Exception as exc:  # noqa: BLE001 - collected for the test
                self.errors.append(repr(exc))
                continue
            self.reads += 1
            if not self.seen or self.seen[-1] != folder.name:
                self.seen.append(folder.name)

    def read_more(self, count: int) -> None:
        """Wait (up to READS_WAIT_S) until the poller has made ``count`` more reads."""
        target, deadline = self.reads + count, time.monotonic() + READS_WAIT_S
        while self.reads < target and time.monotonic() < deadline and self._thread.is_alive():
            time.sleep(0.01)

    def __enter__(self) -> TightPoller:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(10)


@pytest.mark.slow
def test_train_publishes_whole_versions_under_a_tight_poll(tmp_path):
    scene, store = loose_scene(tmp_path), tmp_path / "store"
    base = ["train", "--scene", str(scene), "--quick", "--out", str(store), "--no-progress",
            "--workers", "1", "--seed", "3"]
    assert main(base) == 0
    first = current_version(store)
    with TightPoller(store) as poller:
        assert main([*base[:-1], "4", "--no-reuse"]) == 0  # another seed: a new version
        second = current_version(store)
        poller.read_more(READS_AFTER)  # the poller reads the new version too
    assert second != first and not poller.errors, poller.errors[:3]
    assert poller.seen == [first, second] and poller.reads > 10


@pytest.mark.slow
def test_sweep_show_out_publishes_whole_versions_under_a_tight_poll(tmp_path):
    scene, store = loose_scene(tmp_path), tmp_path / "store"
    assert main(sweep_args(scene, tmp_path / "work", 2)) == 0
    assert current_version(store) is None  # no --out: nothing published
    with TightPoller(store) as poller:
        show = ["sweep", "--study", "tiny", "--workdir", str(tmp_path / "work"), "--show",
                "--out", str(store)]
        assert main(show) == 0
        published = current_version(store)
        poller.read_more(READS_AFTER)
    assert published is not None and not poller.errors, poller.errors[:3]
    assert poller.seen == [published] and poller.reads > 10
