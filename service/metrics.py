"""Prometheus metrics of one app (its own registry, so several apps can live in one process)."""
from __future__ import annotations

import threading

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram, disable_created_metrics

# No `*_created` series: they double the output and no dashboard of ours reads them.
disable_created_metrics()

# Seconds; fine below 10 ms where single-pair requests live, coarse up to big batches.
LATENCY_BUCKETS = (0.0005, 0.001, 0.002, 0.003, 0.005, 0.0075, 0.01, 0.025, 0.05, 0.1, 0.25,
                   0.5, 1.0, 2.0, 5.0, 10.0)
BATCH_BUCKETS = (1, 10, 100, 1_000, 10_000, 100_000, 1_000_000)


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
            "impactnet_http_rejected", "Requests refused before reaching a handler, by reason "
            "(body_too_large, overloaded).", ["reason"], registry=r)
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
        self.ready = Gauge("impactnet_ready", "1 when /readyz answers 200.", registry=r)
        self.model_info = Gauge(
            "impactnet_model_info", "The serving state: 1 for the current model version.",
            ["model_version", "scene", "scene_hash", "modes"], registry=r)
        self._auto_lock = threading.Lock()  # batches are counted from worker threads
        self._auto_pairs = self._auto_fallbacks = 0

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
