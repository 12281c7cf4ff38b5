"""Saturation that persists: what /readyz reports so that an orchestrator notices.

A *streak* is a run of requests refused as ``overloaded`` (no compute slot, or no room in the
memory budget) with no pause longer than :data:`GAP_S` between two refusals. Once a streak has
lasted ``saturation_ready_s``, /readyz answers 503 ``saturated``; a pause of :data:`GAP_S`
without a refusal ends it (a balancer that stopped routing here ends it by itself, so the
replica comes back).
"""
from __future__ import annotations

import time

#: Seconds without a refusal that end a streak: longer than the gaps between the refusals of a
#: busy server (clients retry after Retry-After, 1 s by default), short against a probe period.
GAP_S = 1.5


class Saturation:
    """Refusal streaks (module docstring). Called from the event loop and worker threads;
    the races between them only move a streak's ends by one refusal."""

    def __init__(self, persist_s: float) -> None:
        self.persist_s = persist_s
        self._started: float | None = None
        self._last: float | None = None

    def refused(self) -> None:
        """Record one refusal now."""
        now = time.monotonic()
        if self._last is None or now - self._last > GAP_S:
            self._started = now
        self._last = now

    def reason(self) -> str | None:
        """Why /readyz should say 503, or None while there is no persistent saturation."""
        now = time.monotonic()
        if self._last is None or self._started is None or now - self._last > GAP_S:
            return None
        lasted = now - self._started
        if lasted < self.persist_s:
            return None
        return (f"saturated: requests have been refused as overloaded for {lasted:.0f} s "
                "(compute slots or memory budget full)")
