"""The HTTP service: FastAPI app (``impactnet.service.app.create_app``), schemas, settings, client.

Layout: ``settings`` (one BaseSettings, ``IMPACTNET_*``), ``schemas`` (pydantic request /
response models), ``routers/`` (contact, batch, models, health, metrics, admin),
``predictors`` (modes -> predictors, the immutable serving state), ``state`` (building a
state: scene, learned bundle, checks), ``smoke`` (a bundle's smoke test against the exact
solver), ``reload`` (the admin reload's steps, lock and deadline) and ``bundle_guard`` (the
bundle's files checked before they are read), ``pairs`` (one pair in and out), a batch in
``npz`` / ``batch_json`` (+ ``json_split``, ``scan``) -> ``columns`` -> ``batch_solve`` ->
``answer_encode``, ``body`` (bodies read first: caps, the deadline of ``uploads``, memory),
``budget`` (the process's memory budget and per-request leases), ``middleware`` (request id,
access log, metrics, compute slots; helpers in ``respond``), ``saturation`` (what /readyz
reports), ``json_keys`` (duplicate and unknown keys), ``errors`` (one JSON error envelope),
``cli`` (``impactnet serve``), ``server`` (drain and shutdown), ``client`` (a keep-alive
client for simulators), ``bench_http`` (the HTTP benchmark).

May import `models`; never imports torch or `training`.
"""
