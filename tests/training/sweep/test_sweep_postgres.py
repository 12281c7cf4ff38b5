"""Two sweep workers share one study on a real PostgreSQL server; one is killed with SIGKILL in
the middle of a trial and the other finishes the study: no trial lost, none duplicated."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from impactnet.training.sweep.run import SweepConfig, open_study
from tests.training.sweep.test_sweep import loose_scene

REPO = Path(__file__).resolve().parents[3]
TRIALS = 6
#: Heartbeat and grace period of the workers, seconds (small: the dead worker's trial is
#: retried a few seconds after the kill).
HEARTBEAT_S, GRACE_S = 1, 3
#: Retries of a failed trial (the sweep's --max-retry default).
MAX_RETRY = 2
#: Seconds allowed for the whole study.
STUDY_TIMEOUT_S = 300


def _worker(url: str, scene: Path, workdir: Path) -> subprocess.Popen:
    command = [sys.executable, "-m", "impactnet", "sweep", "--study", "shared", "--storage", url,
               "--scene", str(scene), "--quick", "--trials", str(TRIALS), "--workdir",
               str(workdir), "--timing-rows", "2000", "--heartbeat", str(HEARTBEAT_S),
               "--grace", str(GRACE_S)]
    return subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


def _trials_of(study, pid: int, state: str) -> list:
    return [t for t in study.get_trials(deepcopy=False)
            if t.state.name == state and t.user_attrs.get("worker", "").endswith(f":{pid}")]


def _kill_in_a_trial(study, worker: subprocess.Popen):
    """SIGKILL ``worker`` in the middle of a trial, once it has completed one (so that both
    workers contribute); returns that trial as the storage saw it at the kill.

    The worker is frozen (SIGSTOP) before its running trial is read, so the trial cannot finish
    between the read and the kill; if it is between two trials, it is thawed and tried again.
    """
    deadline = time.monotonic() + STUDY_TIMEOUT_S
    while time.monotonic() < deadline:
        assert worker.poll() is None, worker.stdout.read()
        if _trials_of(study, worker.pid, "COMPLETE"):
            os.kill(worker.pid, signal.SIGSTOP)
            running = [t for t in _trials_of(study, worker.pid, "RUNNING") if t.params]
            if running:
                os.kill(worker.pid, signal.SIGKILL)
                worker.wait()
                return running[0]
            os.kill(worker.pid, signal.SIGCONT)
        time.sleep(0.02)
    pytest.fail("the first worker never ran a second trial")


@pytest.mark.slow
def test_two_workers_share_a_study_and_survive_a_killed_one(postgres_server_url, tmp_path):
    scene = loose_scene(tmp_path)
    first = _worker(postgres_server_url, scene, tmp_path / "a")
    deadline = time.monotonic() + STUDY_TIMEOUT_S
    while True:  # the study exists once the first worker has created it
        try:
            study = open_study(SweepConfig("shared", postgres_server_url, tmp_path))
            break
        except Exception:  # noqa: BLE001 - not created yet
            assert time.monotonic() < deadline and first.poll() is None
            time.sleep(0.2)
    second = _worker(postgres_server_url, scene, tmp_path / "b")
    victim = _kill_in_a_trial(study, first)
    out, _ = second.communicate(timeout=STUDY_TIMEOUT_S)
    assert second.returncode == 0, out

    trials = study.get_trials(deepcopy=False)
    states = [t.state.name for t in trials]
    assert sorted(t.number for t in trials) == list(range(len(trials)))  # none duplicated
    assert states.count("COMPLETE") + states.count("PRUNED") == TRIALS
    assert "RUNNING" not in states and "WAITING" not in states  # none lost in flight
    failed = study.trials[victim.number]
    assert failed.state.name == "FAIL"  # the heartbeat noticed
    # Its work is redone: a retry with the parameters it had drawn (it may have been killed
    # before drawing all of them), retried again if that one fails, until one finishes.
    retry, chain = failed, []
    while retry.state.name == "FAIL":
        retries = [t for t in trials if t.system_attrs.get("failed_trial") == retry.number]
        assert len(retries) == 1, [t.number for t in retries]  # one retry, not duplicated
        retry = retries[0]
        chain.append(retry.number)
        assert failed.params.items() <= retry.params.items()
    assert retry.state.name in ("COMPLETE", "PRUNED") and len(chain) <= MAX_RETRY
    workers = {t.user_attrs["worker"].rsplit(":", 1)[1] for t in trials
               if t.state.name == "COMPLETE"}
    assert workers == {str(first.pid), str(second.pid)}  # both contributed
