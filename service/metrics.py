"""Prometheus metrics of one app (its own registry, so several apps can live in one process)."""
from __future__ import annotations

import os
import threading

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram, disable_created_metrics

# No `*_created` series: they double the output and no dashboard of ours reads them.
disable_created_metrics()

# Seconds; fine below 10 ms where single-pair requests live, coarse up to big batches.
LATENCY_BUCKETS = (0.0005, 0.001, 0.002, 0.003, 0.005, 0.0075, 0.01, 0.025, 0.05, 0.1, 0.25,
                   0.5, 1.0, 2.0, 5.0, 10.0)
BATCH_BUCKETS = (1, 10, 100, 1_000, 10_000, 100_000, 1_000_000)


def resident_bytes() -> float:
    """Resident set size of this process in bytes (0 where /proc is missing)."""
    try:
        with open("/proc/self/statm") as f:
            return float(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0.0


class Metrics:
    """All metrics of the service, registered in :attr:`registry`."""

    def __init__(self) -> None:
        self.registry = r = CollectorRegistry(auto_describe=True)
        self.requests = Counter(
            "impactnet_http_requests", "HTTP requests by route template, method and status.",
            ["route", "method", "status"], registry=r)
        self.latency = Histogram(
            "impactnet_http_request_duration_seconds",
            "Time from the request's arrival to the end of its response, by route.",
            ["route", "method"], buckets=LATENCY_BUCKETS, registry=r)
        self.in_flight = Gauge("impactnet_http_in_flight_requests",
                               "/v1 requests being served now.", registry=r)
        self.rejected = Counter(
            "impactnet_http_rejected", "Requests refused before or while being computed, by "
            "reason (body_too_large, body_timeout, overloaded, memory_budget, and the limit "
            "that refused a request's work or geometry: max_candidates_per_pose, "
            "max_part_contacts_per_batch, max_frustum_sides, ...).", ["reason"], registry=r)
        self.deadline_exceeded = Counter(
            "impactnet_deadline_exceeded", "Requests whose work was stopped at "
            "compute_deadline_s (answered 504).", registry=r)
        self.cancelled = Counter(
            "impactnet_cancelled_work", "Requests whose work was stopped before its end, by "
            "reason (client_disconnected).", ["reason"], registry=r)
        self.budget_limit = Gauge("impactnet_memory_budget_bytes",
                                  "The process's memory budget (settings).", registry=r)
        self.budget_used = Gauge("impactnet_memory_budget_used_bytes",
                                 "Bytes of the memory budget reserved now.", registry=r)
        self.budget_peak = Gauge("impactnet_memory_budget_peak_bytes",
                                 "Most bytes of the memory budget reserved at once.", registry=r)
        self.rss = Gauge("impactnet_process_resident_bytes",
                         "Resident memory of the process now (Linux: /proc).", registry=r)
        self.pairs = Counter(
            "impactnet_pairs_scored", "Box pairs answered, by requested mode and by the "
            "predictor that answered them.", ["mode", "predictor"], registry=r)
        self.batch_size = Histogram("impactnet_batch_pairs", "Pairs per batch request.",
                                    buckets=BATCH_BUCKETS, registry=r)
        self.fallbacks = Counter(
            "impactnet_auto_fallback_pairs", "Pairs that mode 'auto' handed to the exact "
            "solver (unsure or not covered by the bundle).", registry=r)
        self.fallback_rate = Gauge(
            "impactnet_auto_fallback_rate", "Share of all pairs answered in mode 'auto' since "
            "the start that fell back to the exact solver (0 before the first).", registry=r)
        self.reloads = Counter(
            "impactnet_bundle_reloads", "Admin bundle reloads by result (ok, failed) and the "
            "step that failed.", ["result", "step"], registry=r)
        self.follows = Counter(
            "impactnet_store_follows", "New store versions installed by following the store's "
            "'current' pointer.", registry=r)
        self.follow_failures = Counter(
            "impactnet_store_follow_failures", "Failed attempts to follow the store's 'current' "
            "pointer, by the step that failed (the old version kept serving).", ["step"],
            registry=r)
        self.store_info = Gauge(
            "impactnet_store_info", "The followed bundle store: 1 for the version its "
            "'current' named at the last poll and the store version this replica serves.",
            ["current", "served"], registry=r)
        self.ready = Gauge("impactnet_ready", "1 when /readyz answers 200.", registry=r)
        self.model_info = Gauge(
            "impactnet_model_info", "The serving state: 1 for the current model version.",
            ["model_version", "scene", "scene_hash", "modes"], registry=r)
        self._auto_lock = threading.Lock()  # batches are counted from worker threads
        self._auto_pairs = self._auto_fallbacks = 0

    def bind_budget(self, budget) -> None:
        """Export ``budget`` (a :class:`impactnet.service.limits.budget.MemoryBudget`), read at
        scrape time."""
        self.budget_limit.set(budget.limit)
        self.budget_used.set_function(lambda: budget.used)
        self.budget_peak.set_function(lambda: budget.peak)
        self.rss.set_function(resident_bytes)

    def record_answers(self, mode: str, answers) -> None:
        """Count a batch's pairs (an :class:`impactnet.models.dispatch.Answers`) by
        predictor, and its size."""
        import numpy as np

        counts = np.bincount(answers.predictor, minlength=len(answers.predictor_names))
        self.record_predictions(mode, dict(zip(answers.predictor_names.tolist(),
                                               counts.tolist(), strict=True)))
        self.batch_size.observe(len(answers))

    def record_predictions(self, mode: str, predictor_counts: dict[str, int]) -> None:
        """Count the pairs of one request by predictor; in mode 'auto' the rows that the exact
        solver answered are fallbacks."""
        for name, count in predictor_counts.items():
            self.pairs.labels(mode, name).inc(count)
        if mode == "auto":
            fallen = predictor_counts.get("exact", 0)
            self.fallbacks.inc(fallen)
            with self._auto_lock:
                self._auto_pairs += sum(predictor_counts.values())
                self._auto_fallbacks += fallen
                self.fallback_rate.set(self._auto_fallbacks / max(1, self._auto_pairs))
