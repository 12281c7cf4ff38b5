"""Where and for how long a request computes: two lanes of worker threads, a deadline, and the
client's disconnect.

* **Lanes.** Work whose admitted cost is at most ``small_work_max`` box-pair solves (a small
  batch, one compound pair) runs in the *small* lane, a thread of its own; anything larger in
  the *large* lane (``max_batch_workers`` threads). Two large batches therefore never hold up a
  10-pair batch: it waits for at most the small work ahead of it, never for a large one.
* **Deadline.** Each request gets a :class:`impactnet.models.work.WorkLimit` that expires
  ``compute_deadline_s`` after its body arrived; the solvers check it between chunks and stop
  (:class:`impactnet.models.work.WorkStopped`), and the request answers 504
  ``deadline_exceeded``.
* **Disconnect.** While a request computes, its client's connection is watched; when the client
  goes away the same limit is cancelled, and the work stops at its next chunk.
* **Memory.** A step that finds no room in the memory budget gives its thread back
  (:class:`impactnet.service.limits.budget.NeedMemory`), waits for the bytes on the event
  loop in the budget's queue, and runs again with them paid: no worker thread ever waits for
  memory.

A request's steps (parse, admit, solve) may run in different lanes one after another, each
chosen by what is known of the cost at that step (:meth:`Work.run`).
"""
from __future__ import annotations

import asyncio
import contextlib
import contextvars
from concurrent.futures import ThreadPoolExecutor

from starlette.types import Receive

from impactnet.models.work import CANCELLED, WorkLimit, WorkStopped, limited
from impactnet.service.errors import DeadlineExceeded, Overloaded, ServiceError
from impactnet.service.limits.budget import DEFER_WAITS, NeedMemory

#: Threads of the small-work lane: one, so that small work never competes with itself for
#: the two cores, and the large lane keeps its `max_batch_workers`.
SMALL_LANE_THREADS = 1


class ClientGone(ServiceError):
    """The client disconnected and its work was stopped: nobody reads this answer (499, as
    nginx logs a closed request)."""

    def __init__(self) -> None:
        super().__init__(499, "client_closed_request", "the client went away; its work was "
                         "stopped")


class Lanes:
    """The two pools of worker threads (module docstring); at most ``max_queued`` steps wait
    for the large lane (more: 503 before they start, so that a burst of large requests is
    refused, and a front sends them elsewhere, instead of waiting past its deadline)."""

    def __init__(self, large_threads: int, small_work_max: int, max_queued: int) -> None:
        self.large = ThreadPoolExecutor(large_threads, thread_name_prefix="impactnet-batch")
        self.small = ThreadPoolExecutor(SMALL_LANE_THREADS, thread_name_prefix="impactnet-small")
        self.small_work_max, self.max_queued = small_work_max, max_queued
        self.waiting = 0  # steps submitted to the large lane and not started (event loop only)

    def for_cost(self, cost: float) -> ThreadPoolExecutor:
        """The lane of work that costs ``cost`` box-pair solves."""
        return self.small if cost <= self.small_work_max else self.large

    def shutdown(self) -> None:
        for pool in (self.small, self.large):
            pool.shutdown(wait=False, cancel_futures=True)


async def _watch_disconnect(receive: Receive, limit: WorkLimit) -> None:
    """Cancel ``limit`` when the client disconnects (the body has been read already, so the
    next message the server gives is the disconnect)."""
    while True:
        message = await receive()
        if message["type"] == "http.disconnect":
            limit.cancel()
            return


async def _paid(attempt):
    """``await attempt()`` until it runs without :class:`NeedMemory`, the bytes it found
    missing paid on the event loop before each new attempt."""
    while True:
        try:
            return await attempt()
        except NeedMemory as need:
            missing = need
        await missing.lease.prepay(missing)


class Work:
    """The computing steps of one request: one deadline, one disconnect watcher (made by the
    first step run in a lane).

    Parameters
    ----------
    runtime : impactnet.service.runtime.Runtime
        Its lanes, settings and metrics.
    receive : callable
        The request's ASGI ``receive`` (the watcher awaits its disconnect).
    """

    def __init__(self, runtime, receive: Receive) -> None:
        self.runtime = runtime
        self.limit = WorkLimit.after(runtime.settings.compute_deadline_s)
        self._receive = receive
        self._watcher: asyncio.Task | None = None

    async def __aenter__(self) -> Work:
        return self

    def _watch(self) -> None:
        """Watch the client's disconnect from the first step sent to a lane on (work done on
        the event loop, such as a single box pair, cannot see a disconnect before it ends:
        no watcher is made for it)."""
        if self._watcher is None:
            self._watcher = asyncio.create_task(_watch_disconnect(self._receive, self.limit))

    async def __aexit__(self, *exc) -> None:
        if self._watcher is not None and not self._watcher.done():
            self._watcher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._watcher

    async def run(self, cost: float, function, *args):
        """``function(*args)`` in the lane for ``cost``, under the request's limit and with
        its context (the request id); run again after the memory it found missing is paid
        (module docstring); 503 when the large lane's queue is full, 504 past the deadline,
        :class:`ClientGone` when the client left."""
        return await _paid(lambda: self._run_once(cost, function, args))

    async def inline(self, function, *args):
        """``function(*args)`` here on the event loop (work cheaper than a hop to a lane),
        run again after the memory it found missing is paid on the loop."""
        async def attempt():
            token = DEFER_WAITS.set(True)
            try:
                return function(*args)
            finally:
                DEFER_WAITS.reset(token)

        return await _paid(attempt)

    async def _run_once(self, cost: float, function, args: tuple):
        limit, lanes = self.limit, self.runtime.lanes
        self._watch()
        context = contextvars.copy_context()
        pool = lanes.for_cost(cost)
        step = {"waiting": pool is lanes.large}  # in the large lane's queue, not started
        if step["waiting"] and lanes.waiting >= lanes.max_queued:
            raise self._queue_full()
        loop = asyncio.get_running_loop()

        def call():
            loop.call_soon_threadsafe(self._left_queue, step)
            DEFER_WAITS.set(True)
            with limited(limit):
                return function(*args)

        lanes.waiting += step["waiting"]
        try:
            return await loop.run_in_executor(pool, context.run, call)
        except WorkStopped as exc:
            metrics = self.runtime.metrics
            if exc.reason == CANCELLED:
                metrics.cancelled.labels("client_disconnected").inc()
                raise ClientGone() from None
            metrics.deadline_exceeded.inc()
            raise DeadlineExceeded(exc.seconds, self.runtime.settings.compute_deadline_s) \
                from None
        finally:
            self._left_queue(step)

    async def chain(self, cost: float, step, progress, *args):
        """``step(progress, *args, stays)`` in the lane for ``cost``, then again in the lane of
        the progress's next cost (``progress.cost``) until ``progress.done``: ``step`` takes
        as many of its steps as ``stays(next cost)`` allows in the thread it runs in, so that
        a request hops once per change of lane, not once per step (a hop costs ~0.1 ms each
        way)."""
        lanes = self.runtime.lanes
        while True:
            lane = lanes.for_cost(cost)
            progress = await self.run(cost, step, progress, *args,
                                      lambda next_cost, lane=lane: lanes.for_cost(next_cost)
                                      is lane)
            if progress.done:
                return progress
            cost = progress.cost

    def _left_queue(self, step: dict) -> None:
        """A step left the large lane's queue (it started, or it ended without running):
        counted once, on the event loop."""
        if step["waiting"]:
            step["waiting"] = False
            self.runtime.lanes.waiting -= 1

    def _queue_full(self) -> Overloaded:
        runtime = self.runtime
        runtime.metrics.rejected.labels("large_work_queue").inc()
        runtime.saturation.refused()
        return Overloaded(f"{runtime.lanes.max_queued} large requests are waiting for a "
                          "worker already; retry", runtime.settings.retry_after_s)
