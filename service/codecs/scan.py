"""Scans of large request bodies in slices, so that the event loop gets the GIL between them.

``bytes.count`` over a 32 MB body is one C call that holds the GIL for 10-30 ms (longer on a
busy machine), and the event loop's thread cannot answer /healthz meanwhile. Scanned in slices
of :data:`SCAN_BYTES`, the same count is many short calls, between which the interpreter hands
the GIL over (every ``sys.getswitchinterval()``, 5 ms, when another thread waits for it).
"""
from __future__ import annotations

import numpy as np

#: Bytes per C call: 1 MiB takes ~0.3 ms to count (and ~40 ms of Python overhead per 32 MB
#: body in all, for 3 counts).
SCAN_BYTES = 1 << 20


def count(data: bytes, token: bytes, start: int = 0, end: int | None = None) -> int:
    """``data.count(token, start, end)``, in slices (exact: an occurrence that starts in a
    slice is counted there, whole, and only there)."""
    end = len(data) if end is None else end
    reach = len(token) - 1
    return sum(data.count(token, i, min(end, i + SCAN_BYTES + reach))
               for i in range(start, end, SCAN_BYTES))


def contains(data: bytes, token: bytes) -> bool:
    """``token in data`` for a one-byte token, in slices."""
    return any(data.find(token, i, i + SCAN_BYTES) >= 0 for i in range(0, len(data), SCAN_BYTES))


def positions(data: bytes, byte: int) -> np.ndarray:
    """Indices of every occurrence of ``byte`` in ``data`` (int64), in slices."""
    view = np.frombuffer(data, np.uint8)
    parts = [np.flatnonzero(view[i:i + SCAN_BYTES] == byte) + i
             for i in range(0, len(view), SCAN_BYTES)]
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)
