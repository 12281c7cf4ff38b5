"""Replicas follow a bundle store: they poll its ``current`` pointer and load a new version
through the admin reload's verified steps.

Where the served bundle folder is a store (:mod:`impactnet.models.bundle.store`: ``current`` +
``versions/``) and ``store_poll_s`` > 0, :func:`follow` runs beside the server once the first
state is installed, and every ``store_poll_s`` seconds (plus up to :data:`POLL_JITTER` of it,
so that replicas started together do not read shared storage in step) one poll
(:meth:`StoreFollower.poll`) takes these stages:

1. ``peek``: the pointer, read in a worker thread within its size cap
   (:func:`impactnet.service.limits.bundle_guard.store_pointer`): no file read can hold the
   event loop, and a FIFO or a device in its place is refused unopened.
2. ``decide``: nothing to do where the pointer names the store version being served, or the
   one last seen (so an admin reload of an explicit folder holds until ``current`` moves
   again); a version that failed waits out its back-off (below).
3. ``load``: :meth:`impactnet.service.reload.Reloader.reload` of the store folder, in a daemon
   thread of its own (:func:`in_daemon_thread`: a shutdown never waits for it): the admin
   reload's steps (capped files, checksums, scene hash, build, smoke test, warm-up,
   one-assignment install) under its lock and deadline. The store reads its pointer
   once, so the version installed is the one whose files were checked (its
   ``bundle["store_version"]``), even if ``current`` moved meanwhile; the next poll then sees
   the newer one.

A failed load leaves the old version serving, untouched. It is recorded (``GET /v1/models``
``store``, ``impactnet_store_follow_failures_total{step}``, a warning in the log), and the same
version is tried again only after :func:`backoff_s` seconds: ``store_poll_s`` doubled with each
consecutive failure, capped at :data:`BACKOFF_MAX_S`. A different version named by ``current``
(a fix, or a rollback) is tried at the next poll. Shutdown cancels the follower; a load still
running in its thread is never installed once the server drains (the reloader checks).
"""
from __future__ import annotations

import asyncio
import logging
import random
import threading
import time
from pathlib import Path

from impactnet.models.bundle.format import BundleError
from impactnet.service.errors import ReloadFailed
from impactnet.service.limits.bundle_guard import store_pointer
from impactnet.service.reload import Reloader
from impactnet.service.runtime import Runtime
from impactnet.service.state import configured_bundle

log = logging.getLogger("impactnet.service")

#: Largest extra wait of a poll, as a fraction of ``store_poll_s`` (drawn uniformly per poll):
#: replicas started together drift apart instead of reading shared storage in step. 0.1 keeps a
#: fleet's convergence within 1.1 poll intervals plus one load.
POLL_JITTER = 0.1
#: Factor by which the wait before retrying a failing version grows with each consecutive
#: failure (the first retry waits 2 poll intervals, then 4, 8, ...): a broken version costs a
#: replica a few loads (0.3-2 s of a worker thread each), not one per poll.
BACKOFF_FACTOR = 2.0
#: Longest wait in seconds before a failing version is tried again: 5 minutes, so that a
#: transient fault (a shared file system that was briefly unreadable) heals without an operator.
BACKOFF_MAX_S = 300.0
#: Seconds the follower waits beyond a load's own deadline (``reload_timeout_s``), so that a
#: load that gives up by itself (the lock, the install check) reports its own reason.
LOAD_GRACE_S = 1.0


def backoff_s(poll_s: float, failures: int) -> float:
    """Seconds before a version that failed ``failures`` (>= 1) times in a row is tried again:
    ``poll_s * BACKOFF_FACTOR ** failures``, at most :data:`BACKOFF_MAX_S`."""
    return min(BACKOFF_MAX_S, poll_s * BACKOFF_FACTOR ** max(1, failures))


def _settle(future: asyncio.Future, result, error: BaseException | None) -> None:
    """Give ``future`` its outcome unless it was cancelled meanwhile."""
    if future.done():
        return
    if error is not None:
        future.set_exception(error)
    else:
        future.set_result(result)


async def in_daemon_thread(function, *args):
    """``function(*args)`` in a daemon thread of its own, awaited. Unlike
    :func:`asyncio.to_thread`, nothing waits for the thread at shutdown: a load that the
    server no longer wants (it drains) is abandoned, never joined, and never installed."""
    loop = asyncio.get_running_loop()
    future = loop.create_future()

    def target() -> None:
        result, error = None, None
        try:
            result = function(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the awaiting task
            error = exc
        try:
            loop.call_soon_threadsafe(_settle, future, result, error)
        except RuntimeError:  # the loop closed meanwhile: nobody waits for the outcome
            pass

    threading.Thread(target=target, name="impactnet-store-follow", daemon=True).start()
    return await future


class StoreFollower:
    """Follows one store for one runtime (module docstring); its attributes are the status
    that ``GET /v1/models`` shows (:meth:`describe`)."""

    def __init__(self, runtime: Runtime, reloader: Reloader, store: Path, poll_s: float,
                 clock=time.monotonic, rng: random.Random | None = None) -> None:
        self.runtime, self.reloader = runtime, reloader
        self.store = Path(store).expanduser().resolve()  # as the served bundle's `path` says
        self.poll_s = poll_s  # seconds between polls (settings.store_poll_s)
        self.clock = clock  # monotonic seconds (a test passes its own)
        self._rng = rng or random.Random()
        self.current: str | None = None  # what `current` named at the last poll
        self.seen: str | None = self.served()  # store version last installed or found serving
        self.failed: str | None = None  # the version whose loads fail, or None
        self.failures = 0  # consecutive failed loads of `failed`
        self.retry_at: float | None = None  # clock time before which `failed` is not retried
        self.last_follow: dict | None = None  # the last load attempt: time, version, result...
        self._info: tuple[str, str] | None = None  # labels of impactnet_store_info

    def served(self) -> str | None:
        """The store version serving now; None where the serving bundle is not from this
        store (none, or an admin reload of another folder)."""
        state = self.runtime.serving
        bundle = state.bundle if state is not None else None
        if not bundle or bundle.get("path") != str(self.store):
            return None
        return bundle.get("store_version")

    def interval(self) -> float:
        """Seconds until the next poll: ``poll_s`` plus its jitter."""
        return self.poll_s * (1.0 + POLL_JITTER * self._rng.random())

    async def run(self) -> None:
        """Poll at once (the status is then known), then every :meth:`interval` seconds,
        until cancelled or the server drains."""
        while not self.runtime.draining:
            try:
                await self.poll()
            except Exception:  # noqa: BLE001 - a bug here must not end the following
                log.exception("store follow: unexpected failure", extra={"store": str(self.store)})
            await asyncio.sleep(self.interval())

    async def poll(self) -> None:
        """One poll: peek, decide, load where needed (module docstring)."""
        try:
            current = await asyncio.to_thread(store_pointer, self.store)
        except (BundleError, OSError) as exc:
            self._failed(None, "resolve", f"the store's pointer cannot be read: {exc}")
            return
        self.current = current
        served = self.served()
        if current is not None and current not in (served, self.seen):
            waiting = current == self.failed and self.clock() < (self.retry_at or 0.0)
            if not waiting:
                await self._load(current)
                served = self.served()
        elif current is not None:  # in step with the store (again): a failure is history
            self.seen, self.failed, self.failures, self.retry_at = current, None, 0, None
        self._export(current, served)

    async def _load(self, version: str) -> None:
        """Stage ``load`` of ``version`` (what the pointer named) through the reloader."""
        timeout = self.runtime.settings.reload_timeout_s
        try:
            report = await asyncio.wait_for(in_daemon_thread(
                self.reloader.reload, str(self.store), time.monotonic() + timeout, "store"),
                timeout + LOAD_GRACE_S)
        except ReloadFailed as exc:
            if not self.runtime.draining:  # a shutdown is no failure of the version
                self._failed(version, exc.extra["step"], exc.message)
            return
        except TimeoutError:
            self._failed(version, self.reloader.step or "read", f"the load did not finish "
                         f"within {timeout:g} s (reload_timeout_s); nothing was installed")
            return
        self.seen = report.get("store_version") or version
        self.failed, self.failures, self.retry_at = None, 0, None
        self.runtime.metrics.follows.inc()
        self.last_follow = {"at": time.time(), "version": self.seen, "result": "ok",
                            "step": None, "error": None, "seconds": report["seconds"],
                            "model_version": report["model_version"]}
        log.info("followed the store", extra={"store": str(self.store), "version": self.seen,
                                              "model_version": report["model_version"]})

    def _failed(self, version: str | None, step: str, message: str) -> None:
        """Record a failed poll or load; ``version`` None: the pointer itself failed (read
        again at the next poll: reading it costs nothing, loading is what backs off)."""
        self.failures = self.failures + 1 if version == self.failed else 1
        self.failed = version
        delay = self.poll_s if version is None else backoff_s(self.poll_s, self.failures)
        self.retry_at = self.clock() + delay
        self.runtime.metrics.follow_failures.labels(step).inc()
        self.last_follow = {"at": time.time(), "version": version, "result": "failed",
                            "step": step, "error": message, "retry_in_s": round(delay, 3)}
        log.warning("store follow failed", extra={"store": str(self.store), "version": version,
                                                  "step": step, "error": message,
                                                  "failures": self.failures,
                                                  "retry_in_s": round(delay, 3)})

    def _export(self, current: str | None, served: str | None) -> None:
        """``impactnet_store_info{current, served}``: one series, replaced when either moves."""
        labels = (current or "", served or "")
        if labels == self._info:
            return
        gauge = self.runtime.metrics.store_info
        if self._info is not None:
            gauge.remove(*self._info)
        gauge.labels(*labels).set(1)
        self._info = labels

    def describe(self) -> dict:
        """The ``store`` entry of ``GET /v1/models``."""
        served = self.served()
        retry_at = None
        if self.failed is not None and self.retry_at is not None:
            retry_at = time.time() + max(0.0, self.retry_at - self.clock())  # UNIX seconds
        return {"path": str(self.store), "poll_s": self.poll_s, "current": self.current,
                "served": served, "in_sync": self.current is not None and self.current == served,
                "last_follow": self.last_follow, "failures": self.failures,
                "failing_version": self.failed, "retry_at": retry_at}


async def follow(runtime: Runtime, reloader: Reloader, loading: asyncio.Task) -> None:
    """The follower of an app (started by its lifespan): once ``loading`` has installed the
    first state, follow the configured bundle folder every ``store_poll_s`` seconds; nothing
    where that is 0, where no bundle is configured or where the load failed."""
    await asyncio.shield(loading)  # cancelling the follower leaves the load to the lifespan
    poll_s = runtime.settings.store_poll_s
    state = runtime.serving
    if poll_s <= 0 or state is None or not runtime.warm:
        return
    folder = configured_bundle(runtime.settings.bundle, state.scene)
    if folder is None:
        return
    runtime.follower = StoreFollower(runtime, reloader, folder, poll_s)
    await runtime.follower.run()
