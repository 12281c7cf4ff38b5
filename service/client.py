"""A small client for a simulator process: one keep-alive connection, standard library + NumPy.

    from impactnet.service.client import ImpactClient

    with ImpactClient("http://127.0.0.1:8000") as client:
        c = client.contact(a={"object": "container40", "position": [0, 0, 0],
                              "quaternion": [1, 0, 0, 0]},
                           b={"object": "spreader", "position": [0, 0, 1.69],
                              "euler": [0, 0, 0.01]})
        c["point"], c["normal"], c["depth"], c["contact_type"], c["contacts"][0]["part_b"]
        out = client.batch({"a_object": "container40", "a_position": positions_a, ...,
                            "b_object": "spreader", ...})
        out["point"]  # (N, 3) float64, the same columns for box and compound bodies
        contacts_of(out, 0)["part_b"]  # e.g. ['head_fl', 'head_fr'], the deepest first

Dependencies: the standard library and NumPy (orjson, when installed, for speed).
Not thread-safe: one client per thread (a connection carries one request at a time).
Requests are pure functions of their input, so a request that fails on a dropped keep-alive
connection is sent once more on a fresh one.
"""
from __future__ import annotations

import http.client
import json
import urllib.parse
import uuid

import numpy as np

from impactnet.service.codecs.npz_format import read_npz, write_npz

try:  # a runtime dependency of impactnet; the client also works with the standard library
    import orjson
except ImportError:  # pragma: no cover
    orjson = None

JSON = "application/json"
NPZ = "application/x-npz"


class ServiceError(Exception):
    """A non-2xx answer; ``status``, ``error`` (code), ``body`` (the JSON error envelope)."""

    def __init__(self, status: int, body: dict | None, text: str = ""):
        self.status, self.body = status, body or {}
        self.error = self.body.get("error", "http_error")
        super().__init__(f"HTTP {status} {self.error}: {self.body.get('message', text)}")


class ImpactClient:
    def __init__(self, base_url: str = "http://127.0.0.1:8000", timeout: float = 30.0,
                 retries: int = 1) -> None:
        url = urllib.parse.urlsplit(base_url)
        if url.scheme not in ("http", "https"):
            raise ValueError(f"base_url must be http(s)://host:port, got {base_url!r}")
        self._scheme, self._host = url.scheme, url.hostname or "127.0.0.1"
        self._port = url.port or (443 if url.scheme == "https" else 80)
        self._prefix = url.path.rstrip("/")
        self.timeout, self.retries = timeout, retries
        self._conn: http.client.HTTPConnection | None = None
        self.last_model_version: str | None = None  # X-Model-Version of the latest answer
        self.last_request_id: str | None = None
        self._worlds: dict[str, dict] = {}  # registered worlds' requests, to register again

    # ------------------------------------------------------------------ transport

    def _connection(self) -> http.client.HTTPConnection:
        if self._conn is None:
            kind = (http.client.HTTPSConnection if self._scheme == "https"
                    else http.client.HTTPConnection)
            self._conn = kind(self._host, self._port, timeout=self.timeout)
        return self._conn

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self) -> ImpactClient:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def request(self, method: str, path: str, body: bytes | None = None,
                headers: dict[str, str] | None = None) -> tuple[int, dict, bytes]:
        """``(status, headers (lower-case names), body)``; reconnects on a dropped connection."""
        headers = {"X-Request-ID": uuid.uuid4().hex, **(headers or {})}
        for attempt in range(self.retries + 1):
            try:
                conn = self._connection()
                conn.request(method, self._prefix + path, body=body, headers=headers)
                response = conn.getresponse()
                data = response.read()
                out = {k.lower(): v for k, v in response.getheaders()}
                if out.get("connection", "").lower() == "close":
                    self.close()
                self.last_request_id = out.get("x-request-id")
                self.last_model_version = out.get("x-model-version", self.last_model_version)
                return response.status, out, data
            except TimeoutError:
                self.close()
                raise
            except (OSError, http.client.HTTPException):  # dropped keep-alive connection
                self.close()
                if attempt == self.retries:
                    raise
        raise AssertionError("unreachable")

    def _json(self, method: str, path: str, payload=None) -> dict:
        body = None if payload is None else _dumps(payload)
        status, headers, data = self.request(method, path, body,
                                             {"Content-Type": JSON, "Accept": JSON})
        return self._check(status, headers, data)

    @staticmethod
    def _check(status: int, headers: dict, data: bytes):
        if 200 <= status < 300:
            return _loads(data) if headers.get("content-type", "").startswith(JSON) else data
        try:
            body = _loads(data)
        except ValueError:
            body = None
        raise ServiceError(status, body, data[:200].decode("utf-8", "replace"))

    # ------------------------------------------------------------------ API

    def ready(self) -> bool:
        """True when /readyz answers 200."""
        status, _, _ = self.request("GET", "/readyz")
        return status == 200

    def models(self) -> dict:
        return self._json("GET", "/v1/models")

    def reload(self, token: str, bundle: str | None = None) -> dict:
        """POST /v1/admin/reload: swap in the bundle at ``bundle`` (a folder on the server;
        None: the configured one). Returns the report; a failure raises ServiceError whose
        body names the ``step`` that failed (the old bundle keeps serving)."""
        payload = {} if bundle is None else {"bundle": str(bundle)}
        status, headers, data = self.request(
            "POST", "/v1/admin/reload", _dumps(payload),
            {"Content-Type": JSON, "Accept": JSON, "Authorization": f"Bearer {token}"})
        return self._check(status, headers, data)

    def contact(self, a: dict, b: dict, mode: str | None = None, include=(),
                euler_convention: str | None = None, margin: float | None = None) -> dict:
        """One pair. ``a``/``b``: ``{"size" | "object" | "parts", "position", "quaternion" |
        "matrix" | "euler"}`` (lists or arrays). Returns the JSON answer as a dict: the body
        level (``colliding, point, normal, depth, distance, contact_type, feature_a,
        feature_b, predictor, confidence, cluster_size``) and ``contacts``, the part
        contacts, the deepest first. ``margin`` (m): the gap is reported up to it."""
        payload = {"a": a, "b": b, "include": list(include)}
        for key, value in (("mode", mode), ("euler_convention", euler_convention),
                           ("margin", margin)):
            if value is not None:
                payload[key] = value
        return self._json("POST", "/v2/contact", payload)

    def batch(self, columns: dict, mode: str | None = None, include=(),
              euler_convention: str | None = None, margin: float | None = None,
              binary: bool = True) -> dict:
        """N pairs as columns (``a_size`` | ``a_object``, ``a_position``, ``a_quaternion`` |
        ``a_matrix`` | ``a_euler``, same for ``b_``; one value or N), box and compound bodies
        alike. Returns the one answer shape as arrays, whatever the encoding:

        * per pair (N): ``colliding, point, normal, depth, distance`` (inf beyond the margin),
          ``contact_type`` (names), ``feature_a`` / ``feature_b`` (``{part, id, name,
          kind}``), ``predictor``, ``confidence``, ``cluster_size`` (+ ``paper_angles``);
        * ``contacts``: the ragged part contacts with ``offsets`` (N + 1,);
          :func:`contacts_of` gives one pair's;
        * the scalars ``n``, ``mode``, ``model_version``.

        ``binary=True`` sends and receives npz (float64, no JSON round trip); False uses JSON.
        """
        options = {"mode": mode, "include": list(include) or None,
                   "euler_convention": euler_convention, "margin": margin}
        options = {k: v for k, v in options.items() if v is not None}
        if not binary:
            return _arrays(self._json("POST", "/v2/contact/batch", dict(columns) | options))
        query = urllib.parse.urlencode(options, doseq=True)
        status, headers, data = self.request(
            "POST", "/v2/contact/batch" + (f"?{query}" if query else ""),
            write_npz(columns), {"Content-Type": NPZ, "Accept": NPZ})
        self._check(status, headers, data)
        return _nested(read_npz(data))

    def register_world(self, bodies: list[dict], euler_convention: str | None = None) -> str:
        """POST /v2/worlds: register static ``bodies`` (a frame's body objects) on the
        server; returns the world's name. The client keeps them, so that a frame naming the
        world registers it again where a replica does not hold it (409 ``unknown_world``)."""
        payload = {"bodies": bodies} | ({"euler_convention": euler_convention}
                                        if euler_convention else {})
        name = self._json("POST", "/v2/worlds", payload)["world"]
        self._worlds[name] = payload
        return name

    def frame(self, bodies, world: str | None = None, margin: float | None = None,
              mode: str | None = None, include=(), euler_convention: str | None = None,
              pairs: str | None = None) -> dict:
        """POST /v2/frame: every pair of ``bodies`` (and of the registered ``world``) that
        touches or lies within ``margin`` (m).

        ``bodies``: a list of body objects (``{"id", "object" | "size" | "parts",
        "position", "quaternion" | "matrix" | "euler"}``): sent as JSON, the answer is the
        JSON dict (``pairs``: one pair's answer each, with ``a`` and ``b``, the bodies' ids);
        or a dict of columns (``id``, ``object`` | ``size``, ``position``, one orientation):
        sent as npz, the answer is arrays as :meth:`batch` gives them, with ``a`` and ``b``.
        """
        options = {"world": world, "margin": margin, "mode": mode,
                   "include": list(include) or None, "euler_convention": euler_convention,
                   "pairs": pairs}
        options = {k: v for k, v in options.items() if v is not None}
        for attempt in range(2):
            try:
                if isinstance(bodies, dict):
                    return self._frame_npz(bodies, options)
                return self._json("POST", "/v2/frame", {"bodies": list(bodies)} | options)
            except ServiceError as exc:
                if exc.error != "unknown_world" or world not in self._worlds or attempt:
                    raise
                self._json("POST", "/v2/worlds", self._worlds[world])
        raise AssertionError("unreachable")

    def _frame_npz(self, columns: dict, options: dict) -> dict:
        query = urllib.parse.urlencode(options, doseq=True)
        status, headers, data = self.request(
            "POST", "/v2/frame" + (f"?{query}" if query else ""), write_npz(columns),
            {"Content-Type": NPZ, "Accept": NPZ})
        self._check(status, headers, data)
        return _nested(read_npz(data))


#: Scalars of a batch answer.
_SCALARS = {"n": int, "n_bodies": int, "mode": str, "model_version": str}


def _nested(members: dict) -> dict:
    """An npz answer's members (named by path, a contact's with ``contact_`` first) as the
    nested dict of the JSON answer."""
    out: dict = {}
    for name, value in members.items():
        if name in _SCALARS:
            out[name] = _SCALARS[name](value)
            continue
        target, key = out, name
        if key.startswith("contact_") and key != "contact_type":  # the pair's own type
            target, key = out.setdefault("contacts", {}), key.removeprefix("contact_")
        for side in ("feature_a_", "feature_b_"):
            if key.startswith(side):
                target, key = target.setdefault(side[:-1], {}), key.removeprefix(side)
        target[key] = value
    return out


#: Columns of names (a missing name is empty, as in the npz answer).
_TEXT = frozenset({"contact_type", "predictor", "part", "part_a", "part_b", "name", "kind"})
#: Columns of integers, and of booleans.
_INTEGER = frozenset({"id", "offsets", "axis", "cluster_size", "manifold_count"})
_BOOLEAN = frozenset({"colliding"})
#: A row's shape of the columns of numbers that are not one number a row.
_ROW_SHAPE = {"point": (3,), "normal": (3,), "closest_a": (3,), "closest_b": (3,),
              "paper_angles": (4,), "manifold_points": (8, 3), "manifold_depths": (8,)}


def _column(key: str, values: list) -> np.ndarray:
    """One JSON column as the npz answer's array: a missing distance is inf (beyond the
    margin), a missing point or angle row NaN, a missing name empty."""
    if key in _TEXT:
        return np.array(["" if v is None else v for v in values], dtype=str)
    if key in _INTEGER:
        return np.asarray(values, dtype=np.int64)
    if key in _BOOLEAN:
        return np.asarray(values, dtype=bool)
    shape = _ROW_SHAPE.get(key, ())
    missing = np.inf if key == "distance" else np.nan
    rows = [np.full(shape, missing) if v is None else v for v in values]
    return np.array(rows, dtype=np.float64).reshape(len(values), *shape)


def _arrays(body: dict, path: tuple = ()) -> dict:
    """A JSON answer's columns as the npz answer's arrays (:func:`_column`), nested alike."""
    out: dict = {}
    for key, value in body.items():
        if isinstance(value, dict):
            out[key] = _arrays(value, (*path, key))
        elif key in _SCALARS and not path:
            out[key] = value
        else:
            out[key] = _column(key, value)
    return out


def contacts_of(answer: dict, i: int) -> dict:
    """The part contacts of pair ``i`` of a batch answer (columns of its rows, nested as the
    answer's)."""
    contacts = answer["contacts"]
    start, stop = int(contacts["offsets"][i]), int(contacts["offsets"][i + 1])

    def rows(columns: dict) -> dict:
        return {k: rows(v) if isinstance(v, dict) else v[start:stop]
                for k, v in columns.items() if k != "offsets"}
    return rows(contacts)


def _dumps(payload) -> bytes:
    """JSON bytes of the request. (A NaN goes out as null / NaN and comes back as a 422 that
    names the field: the service validates, the client does not repeat it.)"""
    if orjson is not None:
        return orjson.dumps(payload, default=_plain, option=orjson.OPT_SERIALIZE_NUMPY)
    return json.dumps(_plain(payload)).encode()


def _loads(data: bytes):
    return orjson.loads(data) if orjson is not None else json.loads(data)


def _plain(value):
    """Arrays and NumPy scalars as JSON-ready lists / floats (dicts recursively); also orjson's
    ``default`` for what it cannot write itself (non-contiguous or string arrays)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray | np.generic):
        return value.tolist()
    if orjson is not None and not isinstance(value, str | int | float | bool | list | None):
        raise TypeError(f"cannot send {type(value).__name__} as JSON")
    return value
