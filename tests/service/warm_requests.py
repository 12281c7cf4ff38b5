"""Run in a fresh process by tests/service/test_warm_up.py: a server's warm-up
(``compiled.warm_up(serving=True)``, what the runtime runs before ready), then requests of every
kind through the app; prints, as JSON, the kernels whose signatures grew meanwhile (a request
that compiled, or loaded code the warm-up had not)."""
from __future__ import annotations

import io
import json
import sys

import numpy as np

LEVEL = [1.0, 0.0, 0.0, 0.0]


def _dispatchers() -> dict:
    from numba.core.registry import CPUDispatcher

    return {f"{name}.{key}": value for name, module in list(sys.modules.items())
            if name.startswith("impactnet.models")
            for key, value in list(vars(module).items()) if isinstance(value, CPUDispatcher)}


def _body(name: str, position) -> dict:
    return {"object": name, "position": list(position), "quaternion": LEVEL}


def _requests(client) -> None:
    """Pairs (castings, a landing spreader, a cell guide, far apart, an inline frustum), an npz
    batch with a margin, a frame; every answer 200."""
    for a, b, position in (("container40", "container40", (0, 0, 2.589)),
                           ("container40", "spreader", (0, 0.0045, 1.7005)),
                           ("cell_guide", "container40", (0.05, 0, 0.3)),
                           ("container40", "container40", (50, 0, 0))):
        answer = client.post("/v2/contact", json={"a": _body(a, (0, 0, 0)),
                                                  "b": _body(b, position), "margin": 1.0})
        assert answer.status_code == 200, answer.text
    frustum = {"parts": [{"name": "f", "frustum": {"sides": 64, "base": 0.5, "height": 0.3}}],
               "position": [0, 0, 0], "quaternion": LEVEL}
    answer = client.post("/v2/contact", json={"a": frustum, "b": {
        "size": [1, 1, 1], "position": [0, 0, 0.79], "quaternion": LEVEL}})
    assert answer.status_code == 200, answer.text
    rng, n = np.random.default_rng(0), 600  # past the parallel kernels' threshold
    buffer = io.BytesIO()
    np.savez(buffer, a_object=np.array("container40"), b_object=np.array("spreader"),
             a_position=np.zeros(3), a_euler=np.zeros(3),
             b_position=np.array([0, 0.0045, 1.7005]) + rng.uniform(-0.01, 0.01, (n, 3)),
             b_euler=rng.uniform(-0.01, 0.01, (n, 3)))
    answer = client.post("/v2/contact/batch?margin=0.5", content=buffer.getvalue(), headers={
        "Content-Type": "application/x-npz", "Accept": "application/x-npz"})
    assert answer.status_code == 200, answer.text
    bodies = [{"id": f"c{i}", **_body("container40", (0, 2.5 * i, 0))} for i in range(5)]
    bodies += [{"id": "s", **_body("spreader", (0, 0.0045, 1.7005))},
               {"id": "b", "size": [1, 1, 1], "position": [0, 0, 5], "quaternion": LEVEL}]
    answer = client.post("/v2/frame", json={"bodies": bodies, "margin": 1.0})
    assert answer.status_code == 200, answer.text


def main() -> None:
    from fastapi.testclient import TestClient

    from impactnet.models import compiled
    from impactnet.service.app import create_app
    from impactnet.service.settings import Settings

    compiled.warm_up(serving=True)
    settings = Settings(load_in_background=False, access_log=False, bundle="none",
                        scene="quay_crane_detail")
    with TestClient(create_app(settings)) as client:
        before = {name: len(d.signatures) for name, d in _dispatchers().items()}
        _requests(client)
        after = {name: len(d.signatures) for name, d in _dispatchers().items()}
    print(json.dumps({name: [before.get(name, 0), count] for name, count in after.items()
                      if count != before.get(name, 0)}))


if __name__ == "__main__":
    main()
