"""Measured through the HTTP service (``python -m impactnet.service``) on loopback.

Modules
-------
predictors       ``impactnet bench --http``: the benchmark's predictors through the service
moe              ``impactnet bench moe --http``: issue #21's HTTP goals on the detailed scene
hostile          ``impactnet bench hostile``: what each hostile request costs a replica
hostile_attacks  the hostile requests, what a server must answer, and the goals
hostile_report   the Markdown report of ``bench hostile``
service_speed    ``python -m impactnet.training.bench.http.service_speed``: the service's
                 latency and batch throughput against a bare echo server, one client or many
loopback         the shared plumbing: free port, a server waited on, the echo, percentiles
"""
