"""The memory budget's queue: oldest request first, no younger request taking room while an
older one waits, a wait that can never end refused at once, a reservation that could never
fit refused with 413 (service/limits/budget.py)."""
from __future__ import annotations

import asyncio

import pytest

from impactnet.service.errors import Overloaded, PayloadTooLarge
from impactnet.service.limits.budget import (
    DEFER_WAITS,
    PASSING_BYTES,
    Lease,
    MemoryBudget,
    NeedMemory,
)

#: The tests' unit of memory (bytes): reservations of more than one unit queue.
U = 2 * PASSING_BYTES
LIMIT = 100 * U
#: Seconds a test's waiters may wait: long against the few event-loop turns each test takes.
WAIT_S = 5.0


def _turns(n: int = 5):
    """A few turns of the event loop (waiters woken by a release run)."""
    async def turns():
        for _ in range(n):
            await asyncio.sleep(0)
    return turns()


def test_the_oldest_waiting_request_is_served_first_and_a_younger_one_cannot_take_its_room():
    async def scenario():
        budget = MemoryBudget(LIMIT, WAIT_S, 1)
        other, older, younger = Lease(budget), Lease(budget), Lease(budget)
        await other.areserve(90 * U, "another request")
        served = []

        async def wait(lease: Lease, n: int, name: str) -> None:
            await lease.areserve(n, name)
            served.append(name)

        tasks = [asyncio.create_task(wait(younger, 5 * U, "younger"))]
        await _turns()
        tasks.append(asyncio.create_task(wait(older, 50 * U, "older")))
        await _turns()
        assert served == ["younger"]  # it fitted, and nobody older waited then
        assert budget.waiting == 1
        assert not budget.try_reserve(U, younger.age)  # an older request waits: no room
        assert budget.try_reserve(PASSING_BYTES, younger.age)  # a single pair's bytes pass
        assert budget.try_reserve(U, other.age)  # the oldest request may take what fits
        budget.release(PASSING_BYTES + U)
        other.release()
        await asyncio.gather(*tasks)
        assert served == ["younger", "older"] and budget.used == 55 * U
        assert (older.held, younger.held) == (50 * U, 5 * U)

    asyncio.run(scenario())


def test_waiters_are_served_by_age_whatever_order_they_came_in():
    async def scenario():
        budget = MemoryBudget(LIMIT, WAIT_S, 1)
        blocker = Lease(budget)
        await blocker.areserve(LIMIT, "another request")
        leases = [Lease(budget) for _ in range(4)]
        served = []

        async def wait(i: int) -> None:
            await leases[i].areserve(LIMIT // 4, f"request {i}")
            served.append(i)

        tasks = []
        for i in (3, 1, 0, 2):
            tasks.append(asyncio.create_task(wait(i)))
            await _turns()
        blocker.give_back(LIMIT // 4)
        await _turns()
        assert served == [0]
        blocker.release()
        await asyncio.gather(*tasks)
        assert served == [0, 1, 2, 3]

    asyncio.run(scenario())


def test_waiters_that_hold_what_the_oldest_needs_are_refused_at_once_youngest_first():
    async def scenario():
        budget = MemoryBudget(LIMIT, WAIT_S, 1)
        leases = [Lease(budget) for _ in range(3)]
        for lease in leases:
            await lease.areserve(30 * U, "a body")
        started = asyncio.get_running_loop().time()
        waits = [asyncio.create_task(lease.areserve(40 * U, "solving")) for lease in leases]
        # 90 held by waiters leaves 10 for the oldest's 40, even once everything else is
        # released: the youngest gives way at once (60 held leaves the oldest its 40)
        with pytest.raises(Overloaded):
            await waits[2]
        assert asyncio.get_running_loop().time() - started < WAIT_S / 2
        assert budget.waiting == 2
        leases[2].release()  # its 503 is answered
        await waits[0]
        assert leases[0].held == 70 * U and budget.used == 100 * U
        leases[0].release()  # the oldest is answered: the next one fits
        await waits[1]
        assert leases[1].held == 70 * U and budget.used == 70 * U
        assert asyncio.get_running_loop().time() - started < WAIT_S / 2

    asyncio.run(scenario())


def test_a_wait_that_runs_out_is_503_and_lets_the_next_waiter_in():
    async def scenario():
        budget = MemoryBudget(LIMIT, 0.05, 7)
        other, big, small = Lease(budget), Lease(budget), Lease(budget)
        await other.areserve(60 * U, "another request")
        big_wait = asyncio.create_task(big.areserve(50 * U, "a large batch"))
        await _turns()
        small_wait = asyncio.create_task(small.areserve(30 * U, "a small batch"))
        with pytest.raises(Overloaded) as refused:
            await big_wait
        assert refused.value.headers["Retry-After"] == "7"
        await small_wait  # it fitted all along; it waited only behind the older one
        assert budget.used == 90 * U and budget.waiting == 0

    asyncio.run(scenario())


def test_a_reservation_beyond_the_whole_budget_with_what_its_request_holds_is_413():
    async def scenario():
        budget = MemoryBudget(LIMIT, WAIT_S, 1)
        lease = Lease(budget)
        await lease.areserve(60 * U, "a body")
        with pytest.raises(PayloadTooLarge, match=f"with the {60 * U} bytes its request holds"):
            await lease.areserve(50 * U, "solving")
        with pytest.raises(PayloadTooLarge, match="whole budget"):
            await Lease(budget).areserve(LIMIT + 1, "a body")
        assert budget.used == 60 * U

    asyncio.run(scenario())


def test_a_deferred_reservation_without_room_raises_need_memory_and_reserves_nothing():
    budget = MemoryBudget(LIMIT, WAIT_S, 1)
    other, lease = Lease(budget), Lease(budget)
    other.reserve(80 * U, "another request")
    token = DEFER_WAITS.set(True)
    try:
        with pytest.raises(NeedMemory) as need:
            lease.reserve(30 * U, "solving")
    finally:
        DEFER_WAITS.reset(token)
    assert (need.value.n, need.value.lease) == (30 * U, lease)
    assert lease.held == 0 and budget.used == 80 * U


def test_paid_bytes_are_taken_by_the_step_run_again_and_counted_once():
    async def scenario():
        budget = MemoryBudget(LIMIT, WAIT_S, 1)
        lease = Lease(budget)
        await lease.prepay(NeedMemory(30 * U, "solving", lease))
        assert (lease.held, lease.credit, budget.used) == (30 * U, 30 * U, 30 * U)
        lease.reserve(20 * U, "solving")  # from the credit
        lease.reserve(15 * U, "the answer")  # 10 from the credit, 5 more
        assert (lease.held, lease.credit, budget.used) == (35 * U, 0, 35 * U)
        lease.release()
        assert budget.used == 0

    asyncio.run(scenario())


def test_a_waiter_cancelled_in_the_queue_holds_nothing_and_blocks_nobody():
    """An upload's deadline cancels its body read while a chunk waits for room: the waiter
    leaves the queue, and bytes granted to it just before are given back (they were reserved
    for nobody, for ever)."""
    async def scenario():
        budget = MemoryBudget(LIMIT, WAIT_S, 1)
        other, cancelled, younger = Lease(budget), Lease(budget), Lease(budget)
        await other.areserve(90 * U, "another request")
        waiting = asyncio.create_task(cancelled.areserve(50 * U, "a body chunk"))
        await _turns()
        waiting.cancel()
        with pytest.raises(asyncio.CancelledError):
            await waiting
        assert budget.waiting == 0
        after = asyncio.create_task(younger.areserve(8 * U, "a batch"))
        await _turns()
        assert after.done() and budget.used == 98 * U  # nobody older waits any more
        # granted at the moment it was cancelled: given back
        granted = asyncio.create_task(cancelled.areserve(5 * U, "a body chunk"))
        await _turns()
        younger.release()  # grants the waiter, whose task is cancelled before it resumes
        other.release()
        granted.cancel()
        with pytest.raises(asyncio.CancelledError):
            await granted
        assert budget.used == 0 and cancelled.held == 0

    asyncio.run(scenario())
