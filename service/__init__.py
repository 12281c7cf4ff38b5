"""The HTTP service: FastAPI app (``service.app.create_app``), schemas, settings, client.

Layout: ``settings`` (one BaseSettings, ``IMPACTNET_*``), ``schemas`` (pydantic request /
response models), ``routers/`` (contact, batch, models, health, metrics), ``predictors``
(modes -> predictors, the immutable serving state), ``pairs`` / ``columns`` (one pair / a
columnar batch in and out), ``middleware`` (request id, access log, metrics, body and
concurrency limits), ``errors`` (one JSON error envelope), ``cli`` (``impactnet serve``),
``client`` (a keep-alive client for simulators), ``bench_http`` (the HTTP benchmark).

May import `models`; never imports torch or `training`.
"""
