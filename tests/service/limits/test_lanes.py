"""A step that finds no room in the memory budget gives its worker thread back and runs again
once the bytes are paid on the event loop (service/limits/lanes.py, Work.run and
Work.inline)."""
from __future__ import annotations

import asyncio
import threading
from types import SimpleNamespace

from impactnet.service.limits.budget import PASSING_BYTES, Lease, MemoryBudget
from impactnet.service.limits.lanes import Lanes, Work

#: The tests' unit of memory (bytes): more than a reservation that passes the queue.
U = 2 * PASSING_BYTES
LIMIT = 100 * U
WAIT_S = 5.0
#: Box-pair solves of a step sent to the large lane (more than the small lane takes).
LARGE_COST = 1000


async def _connected():
    """A client that stays connected (the disconnect watcher waits for ever)."""
    await asyncio.Event().wait()


def _runtime(large_threads: int = 1) -> SimpleNamespace:
    return SimpleNamespace(lanes=Lanes(large_threads, small_work_max=10, max_queued=4),
                           settings=SimpleNamespace(compute_deadline_s=30.0))


def test_a_step_without_memory_gives_its_worker_back_and_runs_again_once_paid():
    async def scenario():
        runtime, budget = _runtime(), MemoryBudget(LIMIT, WAIT_S, 1)
        other, lease = Lease(budget), Lease(budget)
        other.reserve(80 * U, "another request")
        runs = []

        def solve(n: int) -> int:
            runs.append(threading.current_thread().name)
            lease.reserve(n, "solving")
            return lease.held

        async with Work(runtime, _connected) as work, Work(runtime, _connected) as next_one:
            first = asyncio.create_task(work.run(LARGE_COST, solve, 50 * U))
            while budget.waiting == 0:
                await asyncio.sleep(0.001)
            # the large lane's only thread is free while the first step waits for memory
            assert await next_one.run(LARGE_COST, lambda: "ran") == "ran"
            assert not first.done() and runs and lease.held == 0
            other.release()
            assert await first == 50 * U
        assert len(runs) == 2 and runs[0] == runs[1]  # run again, in the same lane
        assert (lease.held, lease.credit, budget.used) == (50 * U, 0, 50 * U)
        runtime.lanes.shutdown()

    asyncio.run(scenario())


def test_work_on_the_event_loop_waits_for_memory_without_blocking_the_loop():
    async def scenario():
        runtime, budget = _runtime(), MemoryBudget(LIMIT, WAIT_S, 1)
        other, lease = Lease(budget), Lease(budget)
        other.reserve(80 * U, "another request")
        ticks = 0

        async def ticking():
            nonlocal ticks
            while True:
                ticks += 1
                await asyncio.sleep(0)

        def solve(n: int) -> int:
            lease.reserve(n, "solving")
            return lease.held

        clock = asyncio.create_task(ticking())
        async with Work(runtime, _connected) as work:
            answer = asyncio.create_task(work.inline(solve, 30 * U))
            while budget.waiting == 0:
                await asyncio.sleep(0)
            before = ticks
            await asyncio.sleep(0.01)
            assert ticks > before and not answer.done()  # the loop turns while it waits
            other.release()
            assert await answer == 30 * U
        clock.cancel()
        assert budget.used == 30 * U and lease.credit == 0
        runtime.lanes.shutdown()

    asyncio.run(scenario())
