"""Bounded work: a deadline and a cancellation flag that long solves check between chunks.

The solvers answer N rows in bounded chunks (the compound oracle's broadphase and narrowphase,
the batch path of the box predictors). Between two chunks they call :func:`checkpoint`, which
raises :class:`WorkStopped` when the :class:`WorkLimit` of the calling context says the work
must stop: its deadline has passed, or its owner cancelled it (the client that asked for it went
away). A caller that sets no limit (the library used directly) pays one context-variable read
per chunk and never stops.

    limit = WorkLimit.after(30.0)           # seconds of wall time from now
    with limited(limit):
        answer = compound_answer(...)       # raises WorkStopped("deadline") past 30 s
    # from another thread: limit.cancel()  -> WorkStopped("cancelled") at the next chunk

The limit is a :mod:`contextvars` value, so it follows the work into the worker thread that
runs it (``contextvars.copy_context().run``) and is never shared by two requests.
"""
from __future__ import annotations

import contextlib
import contextvars
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

#: Why a piece of work stopped.
DEADLINE = "deadline"
CANCELLED = "cancelled"


class WorkStopped(RuntimeError):
    """The work was stopped at a checkpoint; ``reason`` is :data:`DEADLINE` or
    :data:`CANCELLED`, ``seconds`` the wall time it had run."""

    def __init__(self, reason: str, seconds: float) -> None:
        self.reason, self.seconds = reason, seconds
        super().__init__(f"work stopped ({reason}) after {seconds:.3f} s")


@dataclass
class WorkLimit:
    """When a piece of work must stop: a deadline (``time.monotonic()`` seconds; ``inf``: none)
    and a flag that another thread may set."""

    deadline: float = float("inf")  # time.monotonic() past which the work stops
    started: float = field(default_factory=time.monotonic)  # when the work began
    cancelled: bool = False  # set by cancel(), from any thread (a bool store is atomic)

    @classmethod
    def after(cls, seconds: float) -> WorkLimit:
        """A limit that expires ``seconds`` of wall time from now."""
        now = time.monotonic()
        return cls(deadline=now + seconds, started=now)

    def cancel(self) -> None:
        """Ask the work to stop at its next checkpoint."""
        self.cancelled = True

    def check(self) -> None:
        """Raise :class:`WorkStopped` if the work must stop now."""
        if self.cancelled:
            raise WorkStopped(CANCELLED, time.monotonic() - self.started)
        now = time.monotonic()
        if now > self.deadline:
            raise WorkStopped(DEADLINE, now - self.started)


_LIMIT: contextvars.ContextVar[WorkLimit | None] = contextvars.ContextVar(
    "impactnet_work_limit", default=None)


def checkpoint() -> None:
    """Stop here (:class:`WorkStopped`) if the calling context's limit says so."""
    limit = _LIMIT.get()
    if limit is not None:
        limit.check()


@contextlib.contextmanager
def limited(limit: WorkLimit | None) -> Iterator[WorkLimit | None]:
    """Run the body under ``limit`` (None: no limit); checked once on entry."""
    token = _LIMIT.set(limit)
    try:
        if limit is not None:
            limit.check()
        yield limit
    finally:
        _LIMIT.reset(token)
