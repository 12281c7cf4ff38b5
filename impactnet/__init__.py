"""impactnet: box-box contact for real-time simulation; the command line is `impactnet.cli`."""
from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("impactnet")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.2.0"
