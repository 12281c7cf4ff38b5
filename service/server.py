"""uvicorn's server with a drain phase: readiness drops before the listening socket closes, and
uploads still in progress when it closes end at once instead of holding the exit."""
from __future__ import annotations

import signal
import socket
import threading
from types import FrameType

import uvicorn

from impactnet.service.runtime import Runtime


class Server(uvicorn.Server):
    """On the first SIGTERM / SIGINT: /readyz -> 503 at once, then after ``drain_delay_s``
    uvicorn's graceful shutdown (stop accepting, finish in-flight requests, lifespan exit).
    A second SIGINT (Ctrl+C twice) stops waiting for in-flight requests, as in uvicorn."""

    def __init__(self, config: uvicorn.Config, runtime: Runtime) -> None:
        super().__init__(config)
        self.runtime = runtime
        self._signalled = False

    def handle_exit(self, sig: int, frame: FrameType | None) -> None:
        # Deliberately not recorded in uvicorn's captured signals: after a graceful shutdown
        # `impactnet serve` exits with 0 instead of re-raising the signal and dying by it.
        self.runtime.begin_drain()
        if self._signalled:
            if sig == signal.SIGINT and self.should_exit:
                self.force_exit = True
            self.should_exit = True  # a repeated signal ends the drain delay
            return
        self._signalled = True
        delay = self.runtime.settings.drain_delay_s
        if delay > 0:
            timer = threading.Timer(delay, self._exit)
            timer.daemon = True
            timer.start()
        else:
            self._exit()

    def _exit(self) -> None:
        self.should_exit = True

    async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
        """uvicorn's graceful shutdown, after ending every body still being uploaded (a
        stalled client would otherwise hold the exit for ``graceful_timeout_s``)."""
        self.runtime.begin_drain()
        self.runtime.uploads.expire()
        await super().shutdown(sockets)
