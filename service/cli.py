"""``impactnet serve``: ``add_arguments(parser)`` and ``run(args) -> int``.

Nothing heavy is imported at module level (``impactnet --help`` stays instant): uvicorn and the app
are imported inside :func:`run`. The scene and the bundle are loaded (checksums, scene hash, smoke
test) before the port is bound: a failure exits with status 2. Flags override ``IMPACTNET_*``
environment variables (see :class:`impactnet.service.settings.Settings`); the admin token is read
from the environment only (a flag would show in ``ps``).

Shutdown: the first SIGTERM / SIGINT turns /readyz to 503 at once and every answer says
``Connection: close``; after ``drain_delay_s`` (1 s by default) so that a load balancer can take
the replica out, uvicorn stops accepting, uploads still in progress end with 503, in-flight
requests finish (up to ``graceful_timeout_s``) and the process exits; ``run`` returns 0. A
second signal forces the exit.
"""
from __future__ import annotations

import argparse
import os
import sys

EXIT_CONFIG = 2
#: BLAS / OpenMP thread counts of a server process, unless the environment sets them: one.
#: The service scales with processes (replicas), and batches run in a thread pool; a
#: multi-threaded BLAS inside concurrent requests oversubscribes the cores, and its threads
#: spin: on a busy 2-core machine the learned predictors' float32 matmuls ran 5-20x slower
#: with OpenBLAS's default thread count. Effective only before NumPy is first imported,
#: which :func:`run` ensures for ``impactnet serve`` and ``python -m impactnet.service``.
THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
              "NUMEXPR_NUM_THREADS")

# (flag, settings field, type, help)
_FLAGS = [
    ("--host", "host", str, "interface to bind (default 127.0.0.1; 0.0.0.0 in a container)"),
    ("--port", "port", int, "TCP port (default 8000; 0 picks a free one)"),
    ("--scene", "scene", str, "scene name or TOML path (default quay_crane; '' for none)"),
    ("--bundle", "bundle", str, "learned bundle folder (default: models/bundles/<scene> when "
     "it exists; 'none' for mode exact only)"),
    ("--default-mode", "default_mode", str,
     "mode of requests that name none (default: auto with a bundle, exact without)"),
    ("--max-body-bytes", "max_body_bytes", int, "largest request body (npz; default 64 MiB)"),
    ("--max-json-body-bytes", "max_json_body_bytes", int,
     "largest JSON batch body (default 32 MiB)"),
    ("--max-pair-body-bytes", "max_pair_body_bytes", int,
     "largest body of a single pair or a reload (default 64 KiB)"),
    ("--body-timeout", "body_timeout_s", float,
     "seconds for a request body to arrive, else 408 (default 10)"),
    ("--memory-budget-bytes", "memory_budget_bytes", int,
     "memory budget of bodies, batches and answers (default 512 MiB)"),
    ("--max-batch-pairs", "max_batch_pairs", int, "largest batch (default 100000)"),
    ("--max-concurrency", "max_concurrency", int,
     "most /v1 requests being computed (default 64)"),
    ("--max-batch-workers", "max_batch_workers", int,
     "threads of the large-work lane (default 2)"),
    ("--compute-deadline", "compute_deadline_s", float,
     "seconds a request may compute before its work stops with 504 (default 30)"),
    ("--max-candidates-per-request", "max_candidates_per_request", int,
     "most candidate part pairs of one compound request (default 1000000)"),
    ("--log-level", "log_level", str, "debug, info, warning, error (default info)"),
    # the other limits (max_candidates_per_pose, max_frustum_sides, ...): IMPACTNET_* variables
    ("--graceful-timeout", "graceful_timeout_s", float,
     "seconds to let in-flight requests finish on shutdown (default 30)"),
    ("--drain-delay", "drain_delay_s", float,
     "seconds between SIGTERM (readyz 503) and closing the socket (default 1)"),
]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the serve flags to ``parser`` (every default None: Settings decides)."""
    for flag, dest, kind, text in _FLAGS:
        parser.add_argument(flag, dest=dest, type=kind, default=None, help=text)
    parser.add_argument("--no-access-log", dest="access_log", action="store_false",
                        default=None, help="no JSON access-log line per request")


def settings_from(args: argparse.Namespace):
    from impactnet.service.settings import Settings

    overrides = {dest: getattr(args, dest, None) for _, dest, _, _ in _FLAGS}
    overrides["access_log"] = getattr(args, "access_log", None)
    return Settings(**{k: v for k, v in overrides.items() if v is not None})


def run(args: argparse.Namespace) -> int:
    """Serve until SIGTERM / SIGINT; 0 after a graceful shutdown, 2 for a bad configuration."""
    for name in THREAD_ENV:
        os.environ.setdefault(name, "1")
    from pydantic import ValidationError

    try:
        settings = settings_from(args)
    except ValidationError as exc:
        print(f"impactnet serve: invalid setting: {exc}", file=sys.stderr)
        return EXIT_CONFIG

    import uvicorn

    from impactnet.service import log_setup as service_logging
    from impactnet.service.app import create_app
    from impactnet.service.scene import SceneLoadError
    from impactnet.service.server import Server
    from impactnet.service.state import LoadError, build_state

    try:  # fail fast, before binding: scene, bundle (checksums, scene hash, smoke test)
        state = build_state(settings)
    except SceneLoadError as exc:
        print(f"impactnet serve: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    except LoadError as exc:
        print(f"impactnet serve: cannot serve the bundle (step {exc.step}): {exc}",
              file=sys.stderr)
        return EXIT_CONFIG
    service_logging.configure(settings.log_level)
    app = create_app(settings, state=state)
    config = uvicorn.Config(
        app, host=settings.host, port=settings.port, log_config=None, access_log=False,
        log_level=settings.log_level, timeout_graceful_shutdown=settings.graceful_timeout_s,
        timeout_keep_alive=settings.keepalive_timeout_s, server_header=False,
        lifespan="on", proxy_headers=False)
    server = Server(config, app.state.runtime)
    server.run()
    return 0 if server.started else 1


def main(argv: list[str] | None = None) -> int:
    """``python -m impactnet.service``: the same as ``impactnet serve``."""
    parser = argparse.ArgumentParser(prog="python -m impactnet.service",
                                     description="Serve impactnet over HTTP.")
    add_arguments(parser)
    return run(parser.parse_args(argv))


