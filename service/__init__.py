"""The HTTP service: FastAPI app (``service.app.create_app``), schemas, settings, client.

Layout: ``settings`` (one BaseSettings, ``IMPACTNET_*``), ``schemas`` (pydantic request /
response models), ``routers/`` (contact, batch, models, health, metrics, admin),
``predictors`` (modes -> predictors, the immutable serving state), ``state`` (building a
state: scene, learned bundle, checks), ``smoke`` (a bundle's smoke test against the exact
solver), ``reload`` (the admin reload's steps and lock), ``pairs`` / ``columns`` (one pair / a
columnar batch in and out), ``middleware`` (request id, access log, metrics, body and
concurrency limits), ``errors`` (one JSON error envelope), ``cli`` (``impactnet serve``),
``client`` (a keep-alive client for simulators), ``bench_http`` (the HTTP benchmark).

May import `models`; never imports torch or `training`.
"""
