"""The app's mutable runtime: settings, metrics, the current ServingState, readiness, draining.

Readiness: not ready until the state is loaded and warmed up (:meth:`Runtime.load`), not ready
again from the moment a shutdown begins (:meth:`Runtime.begin_drain`, called on SIGTERM by
:class:`impactnet.service.cli.Server` before uvicorn stops accepting, and by the lifespan's exit).
"""
from __future__ import annotations

import asyncio
import logging
import re
import socket
import time
from importlib.metadata import PackageNotFoundError, version

from impactnet.models import compiled
from impactnet.service.limits.budget import MemoryBudget
from impactnet.service.limits.lanes import Lanes
from impactnet.service.limits.saturation import Saturation
from impactnet.service.limits.trim import Trimmer
from impactnet.service.limits.uploads import Uploads
from impactnet.service.metrics import Metrics
from impactnet.service.predictors import ServingState, settle_heap, warm_up
from impactnet.service.settings import Settings
from impactnet.service.state import build_state
from impactnet.service.worlds import Worlds

log = logging.getLogger("impactnet.service")

#: Characters that a replica name keeps in its header; others become "_" (a header value is
#: latin-1 and must not break the response's framing).
_HEADER_UNSAFE = re.compile(r"[^\x21-\x7e]")
#: Longest replica name in characters (the rest is cut): a header, not a document.
REPLICA_NAME_MAX = 128


def replica_name(settings: Settings) -> str:
    """``settings.replica_name``, else ``<hostname>:<port>``: printable ASCII, at most
    :data:`REPLICA_NAME_MAX` characters."""
    name = settings.replica_name or f"{socket.gethostname()}:{settings.port}"
    return _HEADER_UNSAFE.sub("_", name)[:REPLICA_NAME_MAX]


def package_versions() -> dict[str, str]:
    out = {}
    for name in ("impactnet", "numpy", "fastapi", "pydantic", "uvicorn", "starlette"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "unknown"
    return out


class Runtime:
    """State shared by the middleware and the routers of one app."""

    def __init__(self, settings: Settings, metrics: Metrics | None = None) -> None:
        self.settings = settings
        self.metrics = metrics or Metrics()
        self.serving: ServingState | None = None  # replaced atomically, never mutated
        self.warm = False  # the current state passed warm-up
        self.draining = False
        self.load_error: str | None = None
        self.versions = package_versions()
        self.replica = replica_name(settings)  # the X-Replica header of every answer
        # the store follower (impactnet.service.store_follow), once it runs; None: no store
        self.follower = None
        self.saturation = Saturation(settings.saturation_ready_s)
        self.budget = MemoryBudget(settings.memory_budget_bytes, settings.memory_wait_s,
                                   settings.retry_after_s, on_refusal=self._memory_refused)
        self.metrics.bind_budget(self.budget)
        # bodies being read (impactnet.service.limits.body)
        self.uploads = Uploads(settings.body_timeout_s)
        # Work off the event loop: the small lane (one thread) and the large one
        # (max_batch_workers threads), chosen by each step's admitted cost (limits.lanes).
        self.lanes = Lanes(settings.max_batch_workers, settings.small_work_max,
                           settings.max_queued_large_work)
        # freed memory given back after large requests (limits.trim)
        self.trimmer = Trimmer()
        self.worlds = Worlds(settings.max_worlds)  # registered static worlds (POST /v2/worlds)

    def _memory_refused(self) -> None:
        self.metrics.rejected.labels("memory_budget").inc()
        self.saturation.refused()

    # ------------------------------------------------------------------ readiness

    @property
    def ready(self) -> bool:
        return self.serving is not None and self.warm and not self.draining

    def not_ready_reason(self) -> str | None:
        if self.draining:
            return "draining: the server is shutting down"
        if self.load_error:
            return f"loading failed: {self.load_error}"
        if self.serving is None or not self.warm:
            return "loading: scene and predictors are being loaded and warmed up"
        return None

    def begin_drain(self) -> None:
        if not self.draining:
            self.draining = True
            self.metrics.ready.set(0)
            log.info("draining: /readyz now answers 503")

    # ------------------------------------------------------------------ loading

    def install(self, state: ServingState) -> None:
        """Make ``state`` the one new requests use (one reference assignment: atomic; a
        request that already read the old state finishes with it)."""
        old = self.serving
        self.serving = state
        if old is not None:
            self.metrics.model_info.remove(*self._info_labels(old))
        self.metrics.model_info.labels(*self._info_labels(state)).set(1)

    @staticmethod
    def _info_labels(state: ServingState) -> tuple[str, ...]:
        return (state.model_version, state.scene.name or "", state.scene.hash or "",
                ",".join(state.modes))

    def _build(self, prebuilt: ServingState | None) -> ServingState:
        started = time.perf_counter()
        compiled.set_threads(self.settings.kernel_threads)
        kernels = compiled.warm_up(serving=True)  # compiled or loaded before ready
        log.info("kernels ready", extra={"warm_ups": kernels,
                                         "seconds": round(time.perf_counter() - started, 3)})
        state = prebuilt or build_state(self.settings)
        warm_up(state)
        settle_heap(self.settings)
        return state

    async def load(self, prebuilt: ServingState | None = None) -> None:
        """Load (unless ``prebuilt``) and warm up in a worker thread, then install."""
        started = time.perf_counter()
        try:
            state = await asyncio.to_thread(self._build, prebuilt)
        except Exception as exc:  # noqa: BLE001 - reported by /readyz and the log
            self.load_error = f"{type(exc).__name__}: {exc}"
            log.error("loading failed", extra={"error": self.load_error})
            return
        self.install(state)
        self.warm = True
        self.metrics.ready.set(0 if self.draining else 1)
        log.info("ready", extra={"model_version": state.model_version,
                                 "scene": state.scene.name, "modes": state.modes,
                                 "bundle": state.bundle_path,
                                 "default_mode": state.default_mode,
                                 "seconds": round(time.perf_counter() - started, 3)})
