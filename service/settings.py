"""Service settings: one `BaseSettings`, read from ``IMPACTNET_*`` environment variables.

``impactnet serve`` flags override the environment (see :mod:`impactnet.service.cli`); tests build a
``Settings(...)`` directly. Every default is the safe one: loopback only, bounded bodies,
batches and concurrency, the admin endpoint off.
"""
from __future__ import annotations

from typing import Literal

from pydantic import Field, SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict

KiB = 1024
MiB = 1024 * KiB


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
    # Largest request body in bytes: of an npz batch, and the expanded size of its members
    # (413 beyond it; checked against Content-Length before anything is read, and while the
    # body streams in). The two limits below are lower for other bodies. 64 MiB holds a
    # 100,000-pair batch as npz (~16 MB) with room to spare.
    max_body_bytes: int = Field(64 * MiB, ge=1024)
    # Largest JSON batch body in bytes (413 beyond it). Chosen by measurement: a 100,000-pair
    # batch with quaternions is 26.5 MB of JSON; its columns are parsed one at a time (4-13x
    # a column's size in Python objects), so it needs ~50 MB of the memory budget. Send larger
    # batches (matrices for 100,000 pairs: 52 MB) as npz.
    max_json_body_bytes: int = Field(32 * MiB, ge=1024)
    # Largest body of any other request (a single pair, an admin reload) in bytes (413
    # beyond it). A pair is ~300 bytes; 64 KiB bounds the time that parsing and validating a
    # hostile body holds the event loop (~8 ms for 6,000 unknown keys).
    max_pair_body_bytes: int = Field(64 * KiB, ge=1024)
    # Seconds within which a request body must have arrived in full; later: 408 and the
    # connection is closed. 10 s lets a 64 MiB body through at 54 Mbit/s.
    body_timeout_s: float = Field(10.0, gt=0)
    # Seconds within which a large answer must have been taken by the client; a client that
    # reads slower is disconnected, so that it cannot hold the answer's memory forever.
    send_timeout_s: float = Field(60.0, gt=0)
    # Memory budget of the process in bytes, on top of its footprint when ready: bodies being
    # uploaded, decoded batch columns, the solver's working set and answers being encoded
    # all count against it. A request that would exceed it waits up to `memory_wait_s`, then
    # gets 503 `overloaded` (Retry-After); one that could never fit gets 413. Size it as the
    # container's memory limit minus ~250 MiB (README, "Limits and failure modes").
    memory_budget_bytes: int = Field(512 * MiB, ge=16 * MiB)
    # Seconds a request waits for room in the memory budget before it gets 503.
    memory_wait_s: float = Field(2.0, ge=0)
    # Largest number of pairs in one batch request (413 beyond it).
    max_batch_pairs: int = Field(100_000, ge=1)
    # Most bodies of one frame (POST /v2/frame), its registered world's included, and of one
    # registered world; 413 beyond. The pairs its broadphase finds are held to
    # `max_batch_pairs` (413 `too_many_body_pairs`, the sweep stopped there).
    max_frame_bodies: int = Field(20_000, ge=2)
    # Static worlds a replica keeps (POST /v2/worlds); the least recently used is forgotten
    # past it (a frame naming it then gets 409 `unknown_world`, and the client registers it
    # again).
    max_worlds: int = Field(16, ge=1)
    # Compound bodies: most part contacts one pose may answer with (413 beyond it, checked
    # as the contacts are found, chunk by chunk). Two 40 ft containers at detail 2 stacked
    # castings on castings give 40 (10 ring pieces x 4).
    max_part_contacts_per_pose: int = Field(256, ge=1)
    # Compound bodies: most part contacts one request may answer with (413 beyond it, checked
    # chunk by chunk); each holds ~100 bytes while solved and ~400 of JSON text as it streams.
    max_part_contacts_per_batch: int = Field(1_000_000, ge=1)
    # Compound bodies: most candidate part pairs (the broadphase's survivors, counted before
    # any contact is solved) of one pose (413 beyond it). The shipped scenes' worst training
    # poses have 67 (stacking at detail 2, pushed up to 2 cm; docs/service.md, "Bounded
    # cost"); two 40 ft containers at detail 2 pushed wholly into each other have 237.
    max_candidates_per_pose: int = Field(512, ge=1)
    # Compound bodies: most candidate part pairs of one request (413 beyond it, before any
    # contact is solved): 10,000 spreader landings have ~750,000.
    max_candidates_per_request: int = Field(1_000_000, ge=1)
    # Compound bodies: most distinct pairs of bodies (scene objects, box sizes, inline bodies)
    # among one request's rows that may touch (413 beyond it, before any contact is solved).
    # Each costs a setup of its bodies' tables (2-5 ms for a box against a container; rows
    # of the same pair share it: 256 of them ~1 s on one core); the shipped scenes have at most
    # 5 objects, 25 pairs, so a request of scene objects always passes.
    max_shape_pairs_per_request: int = Field(256, ge=1)
    # Wall-clock seconds a request may compute, from the arrival of its whole body to its
    # answer (queueing for a worker included). Past it the work stops at its next chunk
    # (within a second) and the answer is 504 `deadline_exceeded`, which a front must never
    # replay on another replica (docker/nginx.conf: proxy_read_timeout is longer).
    compute_deadline_s: float = Field(30.0, gt=0)
    # Work whose admitted cost is at most this many box-pair solves (a batch's rows, a compound
    # request's candidate part pairs weighted by their hulls' sizes) runs in the small-work
    # lane, its own worker thread, so that it never waits behind large batches.
    small_work_max: int = Field(4096, ge=1)
    # Steps of large requests that may wait for a large-lane thread (`max_batch_workers`); one
    # more is refused at once with 503 `overloaded` (Retry-After; a fleet's front sends it to
    # another replica) rather than waiting past its deadline. 4: with 2 workers, a request
    # waits behind at most two rounds of large work.
    max_queued_large_work: int = Field(4, ge=0)
    # Inline compound bodies (`parts` in a request): most parts in one body.
    max_inline_parts: int = Field(128, ge=1)
    # Inline parts: most sides of a `frustum` (the shipped twistlock heads have 8-256).
    max_frustum_sides: int = Field(256, ge=3)
    # Inline parts: most points of a `points` part (the hull of the points).
    max_hull_points: int = Field(1024, ge=4)
    # Inline parts: most corners of a `prism`'s section.
    max_section_points: int = Field(256, ge=3)
    # Inline parts: most bytes of one mesh's data once decoded from base64 (a single pair's
    # body is at most `max_pair_body_bytes`).
    max_mesh_bytes: int = Field(48 * KiB, ge=1024)
    # Inline parts: most vertices and triangles of one mesh as loaded (before its hull).
    max_mesh_vertices: int = Field(4096, ge=4)
    max_mesh_faces: int = Field(8192, ge=4)
    # Inline parts: most corners of all the parts of one request together (a frustum of n
    # sides has 2n, a box 8): bounds the hulls built per request (~0.1-0.2 s at the limit).
    max_inline_vertices: int = Field(4096, ge=8)
    # Largest number of /v1 requests being computed at once (from the moment their body has
    # arrived to the start of their answer); more get 503 with Retry-After. Requests still
    # uploading their body, probes (/healthz, /readyz) and /metrics are not counted.
    max_concurrency: int = Field(64, ge=1)
    # Batches solved at once, each in its own worker thread; more wait their turn (their
    # memory is reserved when their turn comes). The solver is CPU-bound, so more threads
    # than cores only add memory and hold the event loop back (the GIL).
    max_batch_workers: int = Field(2, ge=1, le=64)
    # Seconds that requests must have been refused as `overloaded` without a pause before
    # /readyz reports the saturation (503 `saturated`), so that an orchestrator notices.
    saturation_ready_s: float = Field(5.0, gt=0)
    # Seconds a client is told to wait (Retry-After) after a 503.
    retry_after_s: int = Field(1, ge=0)
    # Token of the admin endpoint (POST /v1/admin/reload, `Authorization: Bearer <token>`).
    # None (or "") disables it: the route does not exist (404). Environment only, never a flag.
    admin_token: SecretStr | None = None
    # Seconds an admin reload may take (read, verify, smoke-test, warm up); later it fails
    # with the step it was in, and the bundle it was loading is never installed.
    reload_timeout_s: float = Field(120.0, gt=0)
    # Seconds between two reads of a bundle store's `current` pointer (the bundle folder is a
    # store: `current` + `versions/`). A change is loaded through the admin reload's verified
    # steps and swapped in; a version that fails keeps the old one serving and is retried with
    # back-off (impactnet.service.store_follow). 10 s: a fleet converges within ~11 s plus one
    # load, at the cost of one small file read per replica per poll. 0: the store is not
    # followed (only admin reload changes the bundle).
    store_poll_s: float = Field(10.0, ge=0)
    # Name of this replica in the `X-Replica` header of every answer and in GET /v1/models, so
    # that a client (or a test) behind a balancer sees which replica answered. None or "":
    # "<hostname>:<port>".
    replica_name: str | None = None
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
    # 503 and every answer says `Connection: close`, so that a load balancer takes the
    # replica out and keep-alive clients reconnect elsewhere before the socket closes. 0:
    # close at once (idle keep-alive connections are then cut). Set it to at least the
    # balancer's readiness-probe interval.
    drain_delay_s: float = Field(1.0, ge=0)
    # Seconds an idle keep-alive connection stays open (simulators keep one connection).
    keepalive_timeout_s: float = Field(30.0, gt=0)
    # Load the scene / bundle and warm up in the background, so /healthz answers at once and
    # /readyz says 503 until ready. False: load before the first request is served.
    load_in_background: bool = True
    # Once loaded and warmed up (and after each reload), exempt the objects alive from the
    # cyclic garbage collector's passes (service/predictors.py settle_heap): each full pass
    # stalled the event loop ~70 ms. Tests that build many apps in one process turn it off.
    freeze_heap: bool = True
    # Threads of the compiled kernels' parallel loops (one parallel launch at a time per
    # process: models/compiled.py). None: the cores this process may use; a fleet sets it per
    # replica (docker/compose.yaml: 1 per replica limited to one core).
    kernel_threads: int | None = Field(None, ge=1, le=256)
    # Folder of the compiled kernels' cache (IMPACTNET_KERNEL_CACHE_DIR, read when the kernels
    # are first imported, so environment only). None: next to the sources where writable, else
    # a user or temporary folder (models/compiled.py). An image builds it ahead
    # (docker/Dockerfile) so that a read-only container never compiles.
    kernel_cache_dir: str | None = None
