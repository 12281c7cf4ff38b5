"""One memory budget for the process, in bytes, and the per-request leases drawn from it.

What counts against the budget (``settings.memory_budget_bytes``): the bytes of request bodies
as they arrive (:mod:`impactnet.service.limits.body`), the estimated size of a batch's decoded
columns before they are decoded (:mod:`impactnet.service.codecs.npz`,
:mod:`impactnet.service.codecs.batch_json`), the validated pairs, and the solver's working set
and the answer before they are computed (:mod:`impactnet.service.solve`). Every reservation of
one request goes into its :class:`Lease`, which is released as a whole when the request has
been answered.

A reservation that does not fit waits up to ``memory_wait_s`` for others to be released, then
fails with 503 ``overloaded`` (Retry-After): never an out-of-memory kill. One that could never
fit, being larger than the whole budget, fails at once with 413. The estimates are upper
bounds measured per row or per token (the constants next to each estimate say how).
"""
from __future__ import annotations

import asyncio
import threading
import time

from impactnet.service.errors import Overloaded, PayloadTooLarge

#: Seconds between two tries of a reservation that waits on the event loop: short against
#: `memory_wait_s` (seconds), long enough not to spin.
_ASYNC_POLL_S = 0.01


class MemoryBudget:
    """A thread-safe counter of reserved bytes against a fixed limit.

    Parameters
    ----------
    limit : int
        Bytes that may be reserved at once.
    wait_s : float
        Seconds a reservation waits for room before it fails.
    retry_after_s : int
        Retry-After of the 503 a failed reservation answers.
    on_refusal : callable, optional
        Called (no arguments) each time a reservation is refused for lack of room.
    """

    def __init__(self, limit: int, wait_s: float, retry_after_s: int,
                 on_refusal=None) -> None:
        self.limit, self.wait_s, self.retry_after_s = limit, wait_s, retry_after_s
        self.used = 0
        self.peak = 0
        self._on_refusal = on_refusal
        # The counter takes the plain lock (~0.1 us: every request counts its body); threads
        # that wait for room wait on a condition over the same lock, and are woken only
        # when there are any.
        self._lock = threading.Lock()
        self._room = threading.Condition(self._lock)
        self._waiting = 0

    def _check_size(self, n: int, what: str) -> None:
        if n > self.limit:
            raise PayloadTooLarge("batch_too_large", f"{what} needs {n} bytes of memory, more "
                                  f"than the server's whole budget of {self.limit} bytes; "
                                  "send fewer pairs per request")

    def _take(self, n: int) -> bool:
        """Reserve ``n`` if it fits now (caller holds the lock)."""
        used = self.used + n
        if used > self.limit:
            return False
        self.used = used
        if used > self.peak:
            self.peak = used
        return True

    def _refuse(self, n: int, what: str) -> Overloaded:
        if self._on_refusal is not None:
            self._on_refusal()
        return Overloaded(f"{what} needs {n} bytes of memory and the server's budget of "
                          f"{self.limit} bytes is in use; retry", self.retry_after_s)

    def reserve(self, n: int, what: str) -> None:
        """Reserve ``n`` bytes, waiting (blocking: worker threads only) up to ``wait_s``."""
        self._check_size(n, what)
        deadline = time.monotonic() + self.wait_s
        with self._lock:
            while not self._take(n):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise self._refuse(n, what)
                self._waiting += 1
                try:
                    self._room.wait(left)
                finally:
                    self._waiting -= 1

    async def areserve(self, n: int, what: str) -> None:
        """Reserve ``n`` bytes from the event loop, polling up to ``wait_s``."""
        self._check_size(n, what)
        deadline = time.monotonic() + self.wait_s
        while True:
            with self._lock:
                if self._take(n):
                    return
            if time.monotonic() >= deadline:
                raise self._refuse(n, what)
            await asyncio.sleep(_ASYNC_POLL_S)

    def try_reserve(self, n: int) -> bool:
        """Reserve ``n`` bytes if they fit now, without waiting."""
        with self._lock:
            return self._take(n)

    def release(self, n: int) -> None:
        if n <= 0:
            return
        with self._lock:
            self.used -= n
            if self._waiting:
                self._room.notify_all()


class Lease:
    """The reservations of one request: grown step by step, released once at its end.

    A request's steps run one after another (its body on the event loop, its batch in a
    worker thread, its answer on the loop again), never two at once: ``held`` needs no lock.
    """

    def __init__(self, budget: MemoryBudget) -> None:
        self.budget = budget
        self.held = 0
        self.peak = 0  # most bytes held at once (a large request is followed by a trim)

    def _grew(self, n: int) -> None:
        self.held += n
        self.peak = max(self.peak, self.held)

    def reserve(self, n: int, what: str) -> None:
        """Blocking reservation (worker threads)."""
        self.budget.reserve(n, what)
        self._grew(n)

    async def areserve(self, n: int, what: str) -> None:
        """Reservation from the event loop."""
        if not self.budget.try_reserve(n):
            await self.budget.areserve(n, what)
        self._grew(n)

    def give_back(self, n: int) -> None:
        """Release ``n`` of the held bytes early (a temporary copy that is gone)."""
        n = min(n, self.held)
        self.held -= n
        self.budget.release(n)

    def release(self) -> None:
        """Release everything (the request has been answered)."""
        n, self.held = self.held, 0
        self.budget.release(n)
