"""A replica stopped under load (SIGTERM): no request fails, nginx sends them to the others.

Which mechanism holds (docs/fleet.md, "Draining"): the front buffers request bodies
(``proxy_request_buffering on``), so every request that a draining replica refuses or cuts
(connection refused once its socket is closed, a keep-alive connection closed under a request,
503 for an upload in progress) is sent again, in full, to another replica
(``proxy_next_upstream error timeout http_503 non_idempotent``). A streamed body could not be:
nginx never passes a request on once it has begun sending its body unbuffered.
"""
from __future__ import annotations

import threading
import time

import pytest

from impactnet.service.fleet.local import Fleet
from tests.fleet.helpers import Load, npz_batch, slow_upload

#: Seconds of load before the SIGTERM and after the replica has exited.
STEADY_S = 1.5
#: Seconds between SIGTERM and closing the socket (the replica's drain delay; compose: 2).
DRAIN_DELAY_S = 1.0
#: Pairs per npz batch of the batch clients: 3 MB, more than the front's in-memory body
#: buffer, so that these bodies go through its temp files.
BATCH_PAIRS = 20_000
#: Slow uploads in flight while a replica stops: two per replica, so that a front that streams
#: bodies (round robin) would have sent some of them to the stopping one.
SLOW_UPLOADS = 6
#: Seconds each slow upload takes: longer than the drain delay, so that the stopping replica
#: closes its socket while they are still arriving.
UPLOAD_S = 2.5


@pytest.mark.slow
def test_a_replica_stopped_under_load_fails_no_request(nginx):
    with Fleet(3, ["--bundle", "none", "--no-access-log", "--drain-delay", str(DRAIN_DELAY_S)],
               nginx=nginx) as fleet:
        port = fleet.front.port
        victim = fleet.members[1]
        pairs = Load([port] * 3)
        batches = Load([port] * 2, path="/v2/contact/batch", body=npz_batch(BATCH_PAIRS),
                       content_type="application/x-npz")
        with pairs, batches:
            time.sleep(STEADY_S)
            stopped = time.monotonic()
            victim.terminate()
            assert victim.proc.wait(30) == 0
            exited = time.monotonic()
            time.sleep(STEADY_S)
        front_log = fleet.front.output()

    answers = pairs.answers + batches.answers
    assert not [a for a in answers if a.status != 200], \
        [(a.status, a.error) for a in answers if a.status != 200][:5]
    before = {a.replica for a in answers if a.received < stopped}
    after = {a.replica for a in answers if a.sent > exited}
    assert before == {"r1", "r2", "r3"}
    assert after == {"r1", "r3"}
    assert len([a for a in batches.answers if a.sent > exited]) >= 2  # batches kept flowing
    # nginx met the stopped replica and went on to another: the retries happened
    assert "connect() failed (111: Connection refused)" in front_log, front_log[-2000:]


@pytest.mark.slow
def test_uploads_in_progress_when_a_replica_stops_are_answered_by_another(nginx):
    """The case that decides between the two mechanisms: bodies still arriving when a
    replica stops. Buffered at the front, none of them has reached a replica yet; each is
    sent, complete, to a replica that is still serving."""
    body = npz_batch(BATCH_PAIRS)
    with Fleet(3, ["--bundle", "none", "--no-access-log", "--drain-delay", str(DRAIN_DELAY_S)],
               nginx=nginx) as fleet:
        results: list = [None] * SLOW_UPLOADS

        def upload(i: int) -> None:
            results[i] = slow_upload(fleet.front.port, body, UPLOAD_S)

        threads = [threading.Thread(target=upload, args=(i,)) for i in range(SLOW_UPLOADS)]
        for thread in threads:
            thread.start()
        time.sleep(0.3)  # every upload has begun
        fleet.members[1].terminate()
        for thread in threads:
            thread.join(UPLOAD_S + 30)
        assert fleet.members[1].proc.wait(30) == 0
    assert [r[0] for r in results] == [200] * SLOW_UPLOADS, results
    assert {r[1] for r in results} <= {"r1", "r3"}
