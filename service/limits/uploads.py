"""Deadlines of the request bodies being read, kept by one timer instead of one per request.

An ``asyncio.timeout`` around each body read costs ~5 us per request (a timer scheduled and
cancelled), a tenth of a single pair's whole budget on the event loop. So a body read registers
its task with its deadline (a dict entry), and one timer, armed only while bodies are being
read, sweeps the registrations every :data:`SWEEP_S`: a task past its deadline is cancelled
and marked, and the reader turns that cancellation into its 408 (:meth:`Uploads.expired`).
A deadline is therefore kept to within ``SWEEP_S``.

At shutdown, :meth:`Uploads.expire` ends every read at once, and reads that begin afterwards
expire at the next sweep, so that a stalled client cannot hold the exit.
"""
from __future__ import annotations

import asyncio

#: Seconds between two sweeps of the deadlines: the precision of the body deadline, short
#: against ``body_timeout_s`` (10 s by default); an idle server arms no timer.
SWEEP_S = 0.25


class Uploads:
    """The bodies being read (their tasks and deadlines), on one event loop at a time."""

    def __init__(self, timeout_s: float) -> None:
        self.timeout_s = timeout_s
        self.shutting_down = False
        self._active: dict[asyncio.Task, float] = {}
        self._expired: set[asyncio.Task] = set()
        self._timer: asyncio.TimerHandle | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    def begin(self) -> asyncio.Task:
        """Register the current task's body read; returns the task for :meth:`end`."""
        task = asyncio.current_task()
        loop = task.get_loop()
        self._active[task] = loop.time() + (0.0 if self.shutting_down else self.timeout_s)
        if self._timer is None or self._loop is not loop:  # a test may run several loops
            self._loop = loop
            self._timer = loop.call_later(SWEEP_S, self._sweep)
        return task

    def end(self, task: asyncio.Task) -> None:
        self._active.pop(task, None)
        self._expired.discard(task)

    def expired(self, task: asyncio.Task) -> bool:
        """Whether ``task`` was cancelled for its deadline (then the cancellation is taken
        back, so that the task can answer); False: another cancellation, to re-raise."""
        if task not in self._expired:
            return False
        self._expired.discard(task)
        task.uncancel()
        return True

    def _cancel(self, task: asyncio.Task) -> None:
        self._active.pop(task, None)
        self._expired.add(task)
        task.cancel()

    def _sweep(self) -> None:
        self._timer = None
        now = self._loop.time()
        for task, deadline in list(self._active.items()):
            if deadline <= now:
                self._cancel(task)
        if self._active:
            self._timer = self._loop.call_later(SWEEP_S, self._sweep)

    def expire(self) -> None:
        """Shutdown: every body being read ends now (its request gets 503)."""
        self.shutting_down = True
        for task in list(self._active):
            self._cancel(task)

    def __len__(self) -> int:
        return len(self._active)
