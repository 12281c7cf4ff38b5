"""Markdown pieces shared by the benchmark's reports: a number to a few significant digits, and
the machine line (:func:`impactnet.training.bench.timing.machine_info`'s record in words).

Below every report (``report``, ``speed.section``, ``frame.report``), importing none of them."""
from __future__ import annotations

import os
import shlex
import sys

DASH = "–"


def significant(x, digits: int = 3) -> str:
    """A number with ``digits`` significant digits; a dash for None."""
    if x is None:
        return DASH
    if x == 0:
        return "0"
    return f"{x:.{digits}g}" if abs(x) < 10 ** digits else f"{x:,.0f}"


def machine_line(m: dict) -> str:
    v = m.get("versions", {})
    return (f"{m['cpu']}, {m['cores']} cores ({m.get('cores_usable')} usable), load "
            f"{significant(m.get('load_avg_1m'), 2)} at the start; Python {m['python']}, numpy "
            f"{m['numpy']}, python-fcl {m['python-fcl']}, torch {v.get('torch')}, mujoco "
            f"{v.get('mujoco')}, numba {v.get('numba')}; BLAS / OpenMP pinned to one thread")


def invoked_command(default: str) -> str:
    """The command line that runs this process when it is the ``impactnet`` console script
    (a report names the command that made it, tests/docs checks it), else ``default``."""
    if os.path.basename(sys.argv[0]) == "impactnet" and len(sys.argv) > 1:
        return "impactnet " + shlex.join(sys.argv[1:])
    return default
