"""Service settings: one `BaseSettings`, read from ``IMPACTNET_*`` environment variables.

``impactnet serve`` flags override the environment (see :mod:`service.cli`); tests build a
``Settings(...)`` directly. Every default is the safe one: loopback only, bounded bodies,
batches and concurrency, the admin endpoint off.
"""
from __future__ import annotations

from typing import Literal

from pydantic import Field, SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict

MiB = 1024 * 1024


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="IMPACTNET_", extra="ignore", frozen=True)

    # Interface to bind. 127.0.0.1 keeps the service on this machine; a container sets 0.0.0.0.
    host: str = "127.0.0.1"
    # TCP port.
    port: int = Field(8000, ge=0, le=65535)
    # Scene name (a file in scenes/) or path of a scene TOML; its bodies are the `object` names a
    # request may use. None or "" serves without a scene (raw sizes only).
    scene: str | None = "quay_crane"
    # Learned-predictor bundle folder (modes single / committee / auto). Unset (None): the
    # scene's shipped bundle, models/bundles/<scene name>, when that folder exists, else none.
    # "none" (or ""): no bundle, mode `exact` only. A bundle that cannot be read, fails its
    # checksums or was built for another scene (hash) stops the server at startup.
    bundle: str | None = None
    # Mode used when a request names none. None: "auto" when a bundle is loaded, "exact"
    # otherwise. A mode set here must be served (a learned one needs a bundle).
    default_mode: Literal["exact", "single", "committee", "auto"] | None = None
    # Largest request body in bytes (413 beyond it, checked while the body streams in).
    # 64 MiB holds a 100,000-pair batch as JSON (~40 MB) or as npz (~16 MB).
    max_body_bytes: int = Field(64 * MiB, ge=1024)
    # Largest number of pairs in one batch request (413 beyond it).
    max_batch_pairs: int = Field(100_000, ge=1)
    # Largest number of /v1 requests in flight at once; more get 503 with Retry-After.
    # Probes (/healthz, /readyz) and /metrics are never limited.
    max_concurrency: int = Field(64, ge=1)
    # Seconds a client is told to wait (Retry-After) after a 503.
    retry_after_s: int = Field(1, ge=0)
    # Token of the admin endpoint (POST /v1/admin/reload, `Authorization: Bearer <token>`).
    # None (or "") disables it: the route does not exist (404). Environment only, never a flag.
    admin_token: SecretStr | None = None
    # Generated first-contact poses per bundle pair in the smoke test that a bundle passes
    # against the exact solver before it serves (at startup and on every reload).
    smoke_poses: int = Field(256, ge=8, le=100_000)
    # Log level of the service's JSON logs: debug, info, warning, error.
    log_level: Literal["debug", "info", "warning", "error", "critical"] = "info"
    # Write one JSON access-log line per request (with its request id, status and duration).
    access_log: bool = True
    # Seconds uvicorn waits for in-flight requests on SIGTERM before it closes them.
    graceful_timeout_s: float = Field(30.0, gt=0)
    # Seconds between SIGTERM and closing the listening socket, while /readyz already answers
    # 503, so that a load balancer takes the replica out first. 0: close at once.
    drain_delay_s: float = Field(0.0, ge=0)
    # Seconds an idle keep-alive connection stays open (simulators keep one connection).
    keepalive_timeout_s: float = Field(30.0, gt=0)
    # Load the scene / bundle and warm up in the background, so /healthz answers at once and
    # /readyz says 503 until ready. False: load before the first request is served.
    load_in_background: bool = True
