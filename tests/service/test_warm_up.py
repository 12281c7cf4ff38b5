"""Issue #32, goal 6: compilation never happens inside a request. After the warm-up a server runs
before it says ready (the kernels a request may call; the library's own entries are left to the
install), requests of every kind (compound pairs, a gap, an inline hull, an npz batch over the
parallel kernels, a frame) add no kernel signature. Run in a fresh process, so that no other
test's calls have loaded a signature first."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_no_request_compiles_after_a_server_s_warm_up():
    done = subprocess.run([sys.executable, "-m", "tests.service.warm_requests"], cwd=REPO,
                          capture_output=True, text=True, timeout=1200)
    assert done.returncode == 0, done.stderr[-3000:]
    grown = json.loads(done.stdout.strip().splitlines()[-1])
    assert grown == {}, grown
