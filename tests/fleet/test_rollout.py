"""Rollout: a version published to the fleet's shared store, under a steady load.

Three replicas follow one bundle store (``IMPACTNET_STORE_POLL_S``); publishing is the store's
own two steps, the version folder written atomically and then ``current`` moved atomically.
Every replica serves the new version within the poll interval plus 5 s, no request fails, and
each replica switches its ``X-Model-Version`` once and never back: asked directly on its own
port, and through the front, where ``X-Replica`` names the replica that answered.
"""
from __future__ import annotations

import time

import pytest

from impactnet.models.bundle.store import VERSIONS, set_current
from impactnet.service.fleet.local import Fleet
from tests.fleet.helpers import Answer, Load
from tests.service.learned import write_bundle, write_scene

#: The replicas' store poll interval in seconds (the default is 10; short keeps the test short).
POLL_S = 1.0
#: The issue's bound on convergence: the poll interval plus 5 s (a load and its smoke test).
CONVERGE_S = POLL_S + 5.0
#: Seconds of load before the publication, and after the last replica has switched.
STEADY_S = 1.5
OLD, NEW = "fleet-v1", "fleet-v2"


def switches(answers: list[Answer]) -> list[str]:
    """The versions of ``answers`` (in the order sent) with repeats collapsed."""
    out: list[str] = []
    for answer in answers:
        if not out or out[-1] != answer.version:
            out.append(answer.version)
    return out


def first_new(answers: list[Answer]) -> float | None:
    """When the first answer with the new version was received (None: none yet)."""
    return min((a.received for a in answers if a.version == NEW), default=None)


@pytest.mark.slow
def test_a_published_version_reaches_every_replica_once_and_for_good(nginx, tmp_path):
    scene = write_scene(tmp_path / "scene")
    store = tmp_path / "store"
    write_bundle(store / VERSIONS / OLD, scene, version=OLD)
    set_current(store, OLD)
    args = ["--scene", str(scene), "--bundle", str(store), "--no-access-log"]
    with Fleet(3, args, env={"IMPACTNET_STORE_POLL_S": str(POLL_S)}, nginx=nginx) as fleet:
        names = [m.name for m in fleet.members]
        direct = Load([m.port for m in fleet.members], pause_s=0.02)  # client i: replica i
        front = Load([fleet.front.port] * 2, pause_s=0.005)
        with direct, front:
            time.sleep(STEADY_S)
            write_bundle(store / VERSIONS / NEW, scene, version=NEW)
            published = time.monotonic()
            set_current(store, NEW)
            deadline = published + CONVERGE_S + 2.0  # bounded: the assertions below judge
            while time.monotonic() < deadline and any(
                    first_new(direct.by(i)) is None for i in range(len(names))):
                time.sleep(0.1)
            time.sleep(STEADY_S)

    failed = direct.failures() + front.failures()
    served = len(direct.answers) + len(front.answers)
    print(f"rollout: {served} requests, {len(failed)} failed; seconds from publication to each "
          f"replica's first new answer: "
          f"{[round(first_new(direct.by(i)) - published, 2) for i in range(len(names))]}")
    assert not failed, [(a.status, a.error) for a in failed[:5]]
    for i, name in enumerate(names):
        mine = direct.by(i)
        assert {a.replica for a in mine} == {name}
        assert switches(mine) == [OLD, NEW], (name, switches(mine))
        assert first_new(mine) - published <= CONVERGE_S, (name, first_new(mine) - published)
    for name in names:
        through = [a for a in front.answers if a.replica == name]
        assert {a.version for a in through} == {OLD, NEW}, name
        for client in range(2):  # each front client sends one request after the other
            assert switches([a for a in through if a.client == client]) in (
                [OLD, NEW], [OLD], [NEW]), name
        # never back: nothing sent after the replica's first new answer came back is old
        switched = first_new(through)
        assert not [a for a in through if a.sent > switched and a.version == OLD], name
