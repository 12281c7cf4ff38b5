"""The call chain of one POST /v1/contact in mode auto stays short (issue #19: at most 6 hops).

A profiler hook records, for one request, every call of impactnet's own functions with its
caller among impactnet's functions (a compiled kernel's call is reported to the profiler like a
Python function's); the chain is followed from the route to the separating-axis decision, the
first step of the answer itself: the labeller's (``decision.decide_one``) where the committee
answers, else the exact solver's one-pair kernel (``kernels.solve_one``).
"""
import sys
import threading
from pathlib import Path

from fastapi.testclient import TestClient

from impactnet.service.app import create_app
from tests.service.conftest import test_settings

REPO = Path(__file__).resolve().parents[2]
#: Hops from the route to the separating-axis decision (issue #19's goal: <= 6).
MAX_HOPS = 6
ROUTE = "service/api/routers/contact.py:contact"
#: The separating-axis decision: the labeller's, else the exact solver's one-pair kernel.
DECISIONS = ("models/box/decision.py:decide_one", "models/box/kernels.py:solve_one")
BODY = {"a": {"object": "container40", "position": [0, 0, 0], "quaternion": [1, 0, 0, 0]},
        "b": {"object": "spreader", "position": [0.3, 0.1, 1.69], "quaternion": [1, 0, 0, 0]},
        "mode": "auto"}


class _Recorder:
    """A profiler hook: callee -> caller among impactnet's own functions while ``active``.
    Installed before the test client starts its event-loop thread (``threading.setprofile``
    reaches only threads started after it)."""

    def __init__(self) -> None:
        self.root, self.parents, self.stacks, self.active = str(REPO) + "/", {}, {}, False

    def __call__(self, frame, event, arg):
        if not self.active:
            return
        stack = self.stacks.setdefault(threading.get_ident(), [])
        if event == "call":
            path = frame.f_code.co_filename
            ours = (path.startswith(self.root) and "/.venv/" not in path
                    and "/tests/" not in path)
            name = f"{path[len(self.root):]}:{frame.f_code.co_name}" if ours else None
            caller = next((s for s in reversed(stack) if s), None)
            if name and caller:
                self.parents.setdefault(name, caller)
            stack.append(name)
        elif event == "return" and stack:
            stack.pop()


def test_auto_contact_reaches_the_separating_axis_decision_in_at_most_six_hops():
    bundle = REPO / "models" / "bundles" / "quay_crane"
    settings = test_settings(scene="quay_crane", bundle=str(bundle), smoke_poses=8)
    recorder = _Recorder()
    threading.setprofile(recorder)
    try:
        with TestClient(create_app(settings)) as client:
            client.post("/v1/contact", json=BODY)  # warm-up
            sys.setprofile(recorder)
            recorder.active = True
            assert client.post("/v1/contact", json=BODY).status_code == 200
            recorder.active = False
    finally:
        sys.setprofile(None)
        threading.setprofile(None)
    decided = [name for name in DECISIONS if name in recorder.parents]
    assert decided, f"none of {DECISIONS} was called"
    chain = decided[:1]
    while chain[-1] != ROUTE:
        assert chain[-1] in recorder.parents, f"no caller of {chain[-1]}: {chain}"
        chain.append(recorder.parents[chain[-1]])
    hops = len(chain) - 1
    assert hops <= MAX_HOPS, " <- ".join(chain)
