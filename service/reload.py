"""Admin reload of the learned bundle: built beside the serving one, checked, then swapped.

:meth:`Reloader.reload` runs in a worker thread (the event loop keeps answering) and takes these
steps; the first that fails ends the reload with :class:`impactnet.service.errors.ReloadFailed`
naming it, and the state that was serving keeps serving, untouched:

1. ``resolve``: the folder: the one the request names (relative paths from the server's
   working directory), or the configured one (``settings.bundle``, else the scene's shipped
   bundle); 409 when the server is not ready or has no bundle path to re-read.
2. ``read``, ``scene_hash``, ``build``, ``smoke``: as at startup (:mod:`impactnet.service.state`):
the
   checksums are verified, the bundle must be built for the served scene (the scene is
   kept), every learned mode is built, and the smoke test runs against the exact solver.
3. ``warm_up``: every predictor of the new state answers once.
4. ``install``: :meth:`impactnet.service.runtime.Runtime.install`, one reference assignment. A
request
   that read the old state finishes with it; every later request reads the new one.

Reloads are serialised by a lock: a second one waits for the first, then builds on the
state that the first installed. Steps 1-3 fail with 422 (the bundle is at fault). A replica
that follows a bundle store (:mod:`impactnet.service.store_follow`) loads each new version
through this same method (``source="store"``), under the same lock; its outcomes are counted
by the follower's own metrics, not by ``impactnet_bundle_reloads_total``.

Deadline: a reload has ``reload_timeout_s`` from its request. The route stops waiting then
and answers 422 naming the step in progress; the worker thread, which cannot be stopped,
checks the deadline before ``install`` and never installs a late bundle. A reload that waits
for the lock gives up at the deadline too (409: another reload is still running), so that a
reload stuck on a file can hold up the others only until their own deadlines.
"""
from __future__ import annotations

import logging
import threading
import time
from pathlib import Path

from impactnet.service.errors import ReloadFailed
from impactnet.service.predictors import settle_heap, warm_up
from impactnet.service.runtime import Runtime
from impactnet.service.state import LoadError, configured_bundle, state_for

log = logging.getLogger("impactnet.service")


class Reloader:
    """Serialised reloads of one runtime's bundle."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self._lock = threading.Lock()
        self.step: str | None = None  # the step of the reload in progress, for a late answer

    def _at(self, step: str) -> None:
        self.step = step

    def reload(self, requested: str | None, deadline: float | None = None,
               source: str = "admin") -> dict:
        """Reload from ``requested`` (None: the configured path) before ``deadline`` (a
        :func:`time.monotonic` time; None: none); returns the report. ``source``: who asked,
        ``admin`` (counted in the reload metric) or ``store`` (the store follower)."""
        wait = -1 if deadline is None else max(0.0, deadline - time.monotonic())
        if not self._lock.acquire(timeout=wait):
            old = self.runtime.serving
            raise ReloadFailed(409, "resolve", "another reload is still running (at step "
                               f"{self.step!r}); retry later", requested,
                               old.model_version if old is not None else None)
        try:
            started = time.perf_counter()
            try:
                report = self._reload(requested, deadline)
            except ReloadFailed as exc:
                if source == "admin":
                    self.runtime.metrics.reloads.labels("failed", exc.extra["step"]).inc()
                log.warning("reload failed", extra={"step": exc.extra["step"], "source": source,
                                                    "error": exc.message})
                raise
            report["seconds"] = round(time.perf_counter() - started, 3)
            if source == "admin":
                self.runtime.metrics.reloads.labels("ok", "").inc()
            log.info("reloaded", extra={"source": source} | {k: report[k] for k in (
                "model_version", "previous_model_version", "bundle", "store_version",
                "seconds")})
            return report
        finally:
            self.step = None
            self._lock.release()

    def _reload(self, requested: str | None, deadline: float | None) -> dict:
        runtime = self.runtime
        old = runtime.serving
        serving = old.model_version if old is not None else None
        self._at("resolve")
        if old is None or not runtime.warm or runtime.draining:
            raise ReloadFailed(409, "resolve", "the server is not ready: "
                               f"{runtime.not_ready_reason()}", requested, serving)
        path = (Path(requested).expanduser() if requested
                else configured_bundle(runtime.settings.bundle, old.scene))
        if path is None:
            raise ReloadFailed(409, "resolve", "no bundle path is configured and none was "
                               'given; send {"bundle": "<folder>"}', None, serving)
        try:
            new = state_for(old.scene, path, runtime.settings, on_step=self._at)
            self._at("warm_up")
            warm_up(new)
            settle_heap(runtime.settings)
        except LoadError as exc:
            raise ReloadFailed(422, exc.step, str(exc), str(path), serving) from exc
        except Exception as exc:  # noqa: BLE001 - whatever breaks, the old state keeps serving
            log.exception("reload: unexpected failure", extra={"step": self.step})
            raise ReloadFailed(422, self.step or "read", f"{type(exc).__name__}: {exc}",
                               str(path), serving) from exc
        self._at("install")
        if deadline is not None and time.monotonic() > deadline:
            raise ReloadFailed(422, "install", "the reload's deadline passed; the new bundle "
                               "is not installed", str(path), serving)
        if runtime.draining:  # a shutdown began meanwhile: keep what is serving
            raise ReloadFailed(409, "install", "the server began shutting down", str(path),
                               serving)
        runtime.install(new)
        return {"reloaded": True, "model_version": new.model_version,
                "previous_model_version": serving, "bundle": new.bundle_path,
                "store_version": (new.bundle or {}).get("store_version"),
                "modes": new.modes, "default_mode": new.default_mode,
                "smoke": (new.bundle or {}).get("smoke")}
