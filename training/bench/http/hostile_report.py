"""The Markdown report of `impactnet bench hostile`
(:mod:`impactnet.training.bench.http.hostile`)."""
from __future__ import annotations

import platform

from impactnet.training.bench.http.hostile_attacks import (
    HEALTHZ_P99_GOAL_MS,
    IDLE_SLACK_BYTES,
    REPLICA_BYTES,
    SMALL_BATCH_GOAL_S,
    MiB,
)


def _mark(ok: bool) -> str:
    return "yes" if ok else "**no**"


def _attack_rows(results: dict) -> list[str]:
    budget, deadline = results["budget_mib"], results["deadline_s"]
    rows = ["| attack | statuses | as expected | slowest request (s) | peak over ready (MiB) "
            "| peak (MiB) | /healthz p99 (ms) | CPU (s) | idle 10 s after, over ready (MiB) "
            "| goals met |", "|---|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for a in results["attacks"]:
        ok = (a["expected"] and a["wall_s"] <= deadline and a["peak_over_ready_mib"] <= budget
              and a["peak_mib"] <= REPLICA_BYTES / MiB
              and a["healthz_p99_ms"] <= HEALTHZ_P99_GOAL_MS
              and a["idle_over_ready_mib"] <= IDLE_SLACK_BYTES / MiB)
        rows.append(f"| {a['name']}: {a['what']} | {', '.join(map(str, a['statuses']))} | "
                    f"{_mark(a['expected'])} | {a['wall_s']:.2f} | "
                    f"{a['peak_over_ready_mib']:.0f} | {a['peak_mib']:.0f} | "
                    f"{a['healthz_p99_ms']:.1f} | {a['cpu_s']:.1f} | "
                    f"{a['idle_over_ready_mib']:.0f} | {_mark(ok)} |")
    return rows


def markdown(results: dict) -> str:
    """The report (goals in the module docstring of the bench)."""
    hol, gone, late = results["head_of_line"], results["disconnect"], results["deadline"]
    lines = [
        "# Hostile requests: what each costs a replica",
        "",
        f"`impactnet bench hostile{' --quick' if results['quick'] else ''}` on "
        f"{platform.node()} ({platform.machine()}, Python {platform.python_version()}); scene "
        f"`{results['scene']}`, default settings (memory budget {results['budget_mib']:.0f} "
        f"MiB, compute deadline {results['deadline_s']:g} s), a fresh server per attack, "
        "loopback only.",
        "",
        f"Goals: peak within ready + the budget and within {REPLICA_BYTES // MiB} MiB, every "
        f"request within the deadline, /healthz p99 <= {HEALTHZ_P99_GOAL_MS:g} ms, idle "
        f"memory within ready + {IDLE_SLACK_BYTES // MiB} MiB 10 s after the last request.",
        "",
        *_attack_rows(results),
        "",
        "| mechanism | figure | goal | met |",
        "|---|---|---|---|",
        f"| a 10-pair batch while two large batches run | p50 {hol['small_p50_s']:.3f} s, max "
        f"{hol['small_max_s']:.3f} s ({hol['large_running_at_end']} large still running at "
        f"the end) | <= {SMALL_BATCH_GOAL_S:g} s | "
        f"{_mark(hol['small_max_s'] <= SMALL_BATCH_GOAL_S)} |",
        f"| CPU after the client disconnects at 0.5 s | {gone['cpu_after_disconnect_s']:.2f} s "
        f"| < 1 s | {_mark(gone['cpu_after_disconnect_s'] < 1.0)} |",
        f"| a request past a {late['deadline_s']:g} s deadline | {late['status']} after "
        f"{late['wall_s']:.2f} s | 504 within the deadline + 1 s | "
        f"{_mark(late['status'] == 504 and late['wall_s'] <= late['deadline_s'] + 1.0)} |",
        "",
    ]
    return "\n".join(lines)
