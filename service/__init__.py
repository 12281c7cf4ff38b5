"""The HTTP service: FastAPI app (``impactnet.service.app.create_app``), settings, client.

Layers, top to bottom (nothing below imports from a layer above):

* ``api/``: FastAPI glue: the app's routers (contact, batch, frame, models, health, metrics,
  docs, admin), response schemas, error handlers, middleware, dependencies;
* ``codecs/``: the wire format: requests (``requests``), one pair (``pair``), a frame
  (``frame``), a batch's body (``npz`` / ``batch_json`` with ``json_split`` and ``scan`` ->
  ``columns``), answers (``answers``, ``features``, ``angles``, ``stream``), keys
  (``json_keys``);
* the serving core: ``solve`` (a request's pairs through the one dispatcher, admitted in
  lanes), ``predictors`` (the immutable serving state), ``state`` (building it: scene,
  bundle, smoke test), ``scene``, ``errors`` (the one error envelope), ``limits/`` (bodies,
  the memory budget, lanes and deadlines, saturation, memory trims), ``reload`` and
  ``store_follow`` (new bundles), ``runtime``, ``metrics``, ``settings``;
* ``models``: :mod:`impactnet.models` (the dispatcher and the solvers).

Beside them: ``cli`` (``impactnet serve``), ``server`` (drain and shutdown), ``client`` (a
keep-alive client for simulators), ``probe`` (probes of a server from outside), ``fleet/``. The
HTTP benchmark is :mod:`impactnet.training.bench.http.service_speed`. May import `models`; never
imports torch or `training`.
"""
