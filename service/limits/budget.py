"""One memory budget for the process, in bytes, and the per-request leases drawn from it.

What counts against the budget (``settings.memory_budget_bytes``): the bytes of request bodies
as they arrive (:mod:`impactnet.service.limits.body`), the estimated size of a batch's decoded
columns before they are decoded (:mod:`impactnet.service.codecs.npz`,
:mod:`impactnet.service.codecs.batch_json`), the validated pairs, and the solver's working set
and the answer before they are computed (:mod:`impactnet.service.solve`). Every reservation of
one request goes into its :class:`Lease`, which is released as a whole when the request has
been answered. The estimates are upper bounds measured per row or per token (the constants
next to each estimate say how).

How a reservation that does not fit now is served:

* **It waits on the event loop, never in a worker thread.** A step running in a lane
  (:mod:`impactnet.service.limits.lanes`) that finds no room raises :class:`NeedMemory`; the
  lane's thread is free at once, the request waits for the bytes on the event loop, and the
  step runs again with them paid in advance (the lease's *credit*). A worker thread waiting for
  memory would hold up the requests queued behind it, and those may hold the very memory it
  waits for.
* **First come, first served, by the request's age.** Waiters are served oldest request first,
  and a younger request cannot take room while an older one waits (a large request is not
  starved by a stream of smaller ones), unless it takes at most :data:`PASSING_BYTES` (a single
  pair).
* **No request waits for ever.** A wait ends after ``memory_wait_s`` with 503 ``overloaded``
  and Retry-After. When the memory held by waiting requests leaves too little room for the
  oldest waiter even after every running request has finished, nobody could ever be served
  (each holds what another waits for): the youngest waiters that hold memory are refused at
  once, until the oldest can be served.
* A reservation that could never fit, more than the whole budget with what its request holds
  already, fails at once with 413.
"""
from __future__ import annotations

import asyncio
import contextvars
import heapq
import itertools
import threading
import time
from dataclasses import dataclass, field

from impactnet.service.errors import Overloaded, PayloadTooLarge

#: Whether a reservation that finds no room raises :class:`NeedMemory` (a step in a lane, or
#: run on the event loop by :class:`impactnet.service.limits.lanes.Work`) instead of waiting
#: in its thread (a caller with nothing else running: ``impactnet contact``, the benches).
DEFER_WAITS = contextvars.ContextVar("impactnet_defer_memory_waits", default=False)

#: Request ages: a lease made earlier is served first.
_AGES = itertools.count()
#: Bytes of a reservation that may pass older waiters when it fits now: a single pair's whole
#: body (the default `max_pair_body_bytes`) or solve, answered in about a millisecond. Up to
#: `max_concurrency` of them at once hold back a waiting batch by a few MiB at most, and a
#: simulator's single pairs never wait behind a batch's memory.
PASSING_BYTES = 64 * 1024


class NeedMemory(Exception):  # noqa: N818 - a signal to the lane, not an error
    """A step found no room for ``n`` bytes (``what``) in ``lease``; it is run again once
    they are paid (:meth:`Lease.prepay`)."""

    def __init__(self, n: int, what: str, lease: Lease) -> None:
        super().__init__(what)
        self.n, self.what, self.lease = n, what, lease


@dataclass(order=True)
class _Waiter:
    """A reservation waiting on the event loop (ordered by its request's age)."""

    age: int
    n: int = field(compare=False)
    lease: Lease | None = field(compare=False)
    future: asyncio.Future = field(compare=False)
    what: str = field(compare=False)
    granted: bool = field(default=False, compare=False)
    gone: bool = field(default=False, compare=False)  # timed out or refused


class MemoryBudget:
    """A thread-safe counter of reserved bytes against a fixed limit (module docstring).

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
        # that wait for room (outside the server) wait on a condition over the same lock.
        self._lock = threading.Lock()
        self._room = threading.Condition(self._lock)
        self._thread_waiting = 0
        self._queue: list[_Waiter] = []  # a heap: the oldest request's waiter first

    @property
    def waiting(self) -> int:
        """Reservations waiting on the event loop."""
        return sum(not w.gone for w in self._queue)

    def check_size(self, n: int, what: str, held: int = 0) -> None:
        """413 where ``n`` bytes, with the ``held`` bytes of their request, could never fit."""
        if n + held > self.limit:
            more = f" with the {held} bytes its request holds already" if held else ""
            raise PayloadTooLarge("batch_too_large", f"{what} needs {n} bytes of memory{more}, "
                                  f"more than the server's whole budget of {self.limit} bytes; "
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

    def _head(self) -> _Waiter | None:
        """The oldest live waiter (caller holds the lock)."""
        while self._queue and self._queue[0].gone:
            heapq.heappop(self._queue)
        return self._queue[0] if self._queue else None

    def _may_take(self, n: int, age: int | None) -> bool:
        """Reserve ``n`` now unless an older request waits and ``n`` is more than
        :data:`PASSING_BYTES` (caller holds the lock)."""
        head = self._head()
        if head is not None and (age is None or head.age < age) and n > PASSING_BYTES:
            return False
        return self._take(n)

    def _refuse(self, n: int, what: str) -> Overloaded:
        if self._on_refusal is not None:
            self._on_refusal()
        return Overloaded(f"{what} needs {n} bytes of memory and the server's budget of "
                          f"{self.limit} bytes is in use; retry", self.retry_after_s)

    def reserve(self, n: int, what: str) -> None:
        """Reserve ``n`` bytes, waiting in this thread up to ``wait_s`` (callers with nothing
        else running; the server's steps wait on the event loop: :class:`NeedMemory`)."""
        self.check_size(n, what)
        deadline = time.monotonic() + self.wait_s
        with self._lock:
            while not self._may_take(n, None):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise self._refuse(n, what)
                self._thread_waiting += 1
                try:
                    self._room.wait(left)
                finally:
                    self._thread_waiting -= 1

    def try_reserve(self, n: int, age: int | None = None) -> bool:
        """Reserve ``n`` bytes if they fit now and no request older than ``age`` waits."""
        with self._lock:
            return self._may_take(n, age)

    async def areserve(self, n: int, what: str, lease: Lease | None = None) -> None:
        """Reserve ``n`` bytes from the event loop, in the queue (module docstring), waiting up
        to ``wait_s``; ``lease``: the request's (its age and what it holds)."""
        self.check_size(n, what, lease.held if lease is not None else 0)
        age = lease.age if lease is not None else next(_AGES)
        with self._lock:
            if self._may_take(n, age):
                return
            waiter = _Waiter(age, n, lease, asyncio.get_running_loop().create_future(), what)
            heapq.heappush(self._queue, waiter)
            self._grant()
            self._break_deadlock()
        try:
            await asyncio.wait_for(asyncio.shield(waiter.future), self.wait_s)
        except TimeoutError:
            pass
        except BaseException:  # refused at once, or cancelled (an upload's deadline)
            self._abandon(waiter)
            raise
        with self._lock:
            if waiter.granted:
                return
            self._left(waiter)
        raise self._refuse(n, what)

    def _left(self, waiter: _Waiter) -> None:
        """``waiter`` leaves the queue ungranted (caller holds the lock)."""
        waiter.gone = True
        waiter.future.cancel()  # nothing settles it any more
        self._grant()  # the next waiter may fit where this one did not

    def _abandon(self, waiter: _Waiter) -> None:
        """A waiter whose request stopped waiting: out of the queue, and the bytes granted to
        it just before given back (its lease never counted them)."""
        with self._lock:
            if waiter.granted:
                self.used -= waiter.n
                waiter.granted = False
                self._grant()
                if self._thread_waiting:
                    self._room.notify_all()
            elif not waiter.gone:
                self._left(waiter)

    def _grant(self) -> None:
        """Serve waiters, oldest first, while the oldest fits (caller holds the lock)."""
        while (head := self._head()) is not None and self._take(head.n):
            heapq.heappop(self._queue)
            head.granted = True
            head.future.get_loop().call_soon_threadsafe(_settle, head.future, None)

    def _break_deadlock(self) -> None:
        """Refuse the youngest waiters that hold memory while what all waiters hold leaves
        too little room for the oldest (caller holds the lock; module docstring)."""
        while (head := self._head()) is not None:
            live = [w for w in self._queue if not w.gone]
            if self.limit - sum(w.lease.held for w in live if w.lease) >= head.n:
                return
            holders = [w for w in live if w is not head and w.lease and w.lease.held]
            if not holders:
                return
            youngest = max(holders)
            youngest.gone = True
            exc = self._refuse(youngest.n, youngest.what)
            youngest.future.get_loop().call_soon_threadsafe(_settle, youngest.future, exc)

    def release(self, n: int) -> None:
        if n <= 0:
            return
        with self._lock:
            self.used -= n
            self._grant()
            if self._thread_waiting:
                self._room.notify_all()


def _settle(future: asyncio.Future, exc: Exception | None) -> None:
    """End a waiter's future (on its loop): granted, or refused with ``exc``."""
    if not future.done():
        if exc is None:
            future.set_result(None)
        else:
            future.set_exception(exc)


class Lease:
    """The reservations of one request: grown step by step, released once at its end.

    A request's steps run one after another (its body on the event loop, its batch in a
    worker thread, its answer on the loop again), never two at once: ``held`` needs no lock.
    ``credit``: bytes paid in advance on the event loop for a step run again
    (:class:`NeedMemory`), taken by its reservations first. A step that found no room keeps
    what it had reserved before it (the state it kept may use it): a step run again may
    count some bytes twice, never too few.
    """

    def __init__(self, budget: MemoryBudget) -> None:
        self.budget = budget
        self.age = next(_AGES)
        self.held = 0
        self.credit = 0
        self.peak = 0  # most bytes held at once (a large request is followed by a trim)

    def _grew(self, n: int) -> None:
        self.held += n
        self.peak = max(self.peak, self.held)

    def reserve(self, n: int, what: str) -> None:
        """Reservation in a thread: from the credit first; then, under
        :data:`DEFER_WAITS`, :class:`NeedMemory` when there is no room now, else a wait in
        this thread."""
        paid = min(n, self.credit)
        self.credit -= paid
        n -= paid
        if n <= 0:
            return
        if DEFER_WAITS.get():
            self.budget.check_size(n, what, self.held)
            if not self.budget.try_reserve(n, self.age):
                raise NeedMemory(n, what, self)
        else:
            self.budget.reserve(n, what)
        self._grew(n)

    async def areserve(self, n: int, what: str) -> None:
        """Reservation from the event loop."""
        if not self.budget.try_reserve(n, self.age):
            await self.budget.areserve(n, what, self)
        self._grew(n)

    async def prepay(self, need: NeedMemory) -> None:
        """Pay ``need.n`` bytes on the event loop, for the step that raised ``need`` to take
        when it runs again."""
        await self.areserve(need.n, need.what)
        self.credit += need.n

    def give_back(self, n: int) -> None:
        """Release ``n`` of the held bytes early (a temporary copy that is gone)."""
        n = min(n, self.held)
        self.held -= n
        self.credit = min(self.credit, self.held)
        self.budget.release(n)

    def release(self) -> None:
        """Release everything (the request has been answered)."""
        n, self.held, self.credit = self.held, 0, 0
        self.budget.release(n)
