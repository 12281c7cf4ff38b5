"""Freed memory given back to the system after large requests (glibc's ``malloc_trim``).

NumPy's arrays are freed when a request ends, but glibc keeps the freed pages of its arenas for
reuse, and raises its mmap threshold after large frees, so that the next large arrays come from the
arenas too: a replica that once served a 1 GB batch stayed at 1.0-1.6 GB resident while idle. After
a request whose lease held more than :data:`TRIM_AFTER_BYTES` (or that ran longer than
:data:`TRIM_AFTER_S`), once no such request has ended for :data:`TRIM_DELAY_S`, the process calls
``malloc_trim(0)`` (in a worker thread: it walks every arena), which returns the free pages of every
arena. Where the C library has no ``malloc_trim`` (not glibc), nothing is done.
"""
from __future__ import annotations

import asyncio
import ctypes
import ctypes.util
import logging

log = logging.getLogger("impactnet.service")

#: A request that held more of the memory budget than this (bytes) is followed by a trim:
#: small requests reuse the arenas' pages at once, and trimming after each would cost more
#: than it returns.
TRIM_AFTER_BYTES = 16 << 20
#: A request that took longer than this (seconds) is followed by a trim too: long work
#: allocates, whatever its lease says (a compound count refused before its reservation).
TRIM_AFTER_S = 0.25
#: Seconds after the last large request before the trim: a burst of large requests reuses
#: its pages, and the trim runs once the burst is over.
TRIM_DELAY_S = 1.0


def _malloc_trim():
    """glibc's ``malloc_trim``, or None."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


class Trimmer:
    """Schedules one trim after each burst of large requests (module docstring)."""

    def __init__(self) -> None:
        self._trim = _malloc_trim()
        self._timer: asyncio.TimerHandle | None = None
        self.trims = 0  # trims done (tests and metrics)

    def released(self, peak_bytes: int, seconds: float = 0.0) -> None:
        """A request that held ``peak_bytes`` at most and took ``seconds`` has ended (called
        on the event loop)."""
        if self._trim is None or (peak_bytes <= TRIM_AFTER_BYTES and seconds <= TRIM_AFTER_S):
            return
        loop = asyncio.get_running_loop()
        if self._timer is not None:
            self._timer.cancel()
        self._timer = loop.call_later(TRIM_DELAY_S, self._start)

    def _start(self) -> None:
        self._timer = None
        asyncio.get_running_loop().run_in_executor(None, self.trim_now)

    def trim_now(self) -> None:
        """Give the free pages of every arena back now (blocking; a worker thread)."""
        if self._trim is not None:
            self._trim(0)
            self.trims += 1
