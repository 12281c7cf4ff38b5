"""A small client for a simulator process: one keep-alive connection, standard library + NumPy.

    from impactnet.service.client import ImpactClient

    with ImpactClient("http://127.0.0.1:8000") as client:
        c = client.contact(a={"object": "container40", "position": [0, 0, 0],
                              "quaternion": [1, 0, 0, 0]},
                           b={"object": "spreader", "position": [0, 0, 1.69],
                              "euler": [0, 0, 0.01]})
        c["point"], c["normal"], c["depth"], c["contact_type"]
        out = client.batch({"a_object": "container40", "a_position": positions_a, ...})
        out["point"]  # (N, 3) float64
        # compound scene objects: summary columns, and the part contacts of each row
        out = client.batch({"a_object": "container40", "b_object": "spreader", ...})
        contacts_of(out, 0)["part_b"]  # e.g. ['head_fl', 'head_fr']

Dependencies: the standard library and NumPy (orjson, when installed, for speed).
Not thread-safe: one client per thread (a connection carries one request at a time).
Requests are pure functions of their input, so a request that fails on a dropped keep-alive
connection is sent once more on a fresh one.
"""
from __future__ import annotations

import http.client
import io
import json
import urllib.parse
import uuid

import numpy as np

try:  # a runtime dependency of impactnet; the client also works with the standard library
    import orjson
except ImportError:  # pragma: no cover
    orjson = None

JSON = "application/json"
NPZ = "application/x-npz"
#: impactnet.models.contacts.CONTACT_TYPES, repeated so that the client needs only NumPy.
CONTACT_TYPES = ("none", "vertex-face", "face-vertex", "edge-edge", "edge-face", "face-edge",
                 "face-face")


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
                euler_convention: str | None = None) -> dict:
        """One pair. ``a``/``b``: ``{"size" | "object", "position", "quaternion" | "matrix" |
        "euler"}`` (lists or arrays). Returns the JSON answer as a dict."""
        payload = {"a": a, "b": b, "include": list(include)}
        if mode is not None:
            payload["mode"] = mode
        if euler_convention is not None:
            payload["euler_convention"] = euler_convention
        return self._json("POST", "/v1/contact", payload)

    def batch(self, columns: dict, mode: str | None = None, include=(),
              euler_convention: str | None = None, binary: bool = True) -> dict[str, np.ndarray]:
        """N pairs as columns (``a_size`` | ``a_object``, ``a_position``, ``a_quaternion`` |
        ``a_matrix`` | ``a_euler``, same for ``b_``; one value or N). Returns arrays:
        ``colliding, point, normal, depth, contact_type (names), contact_type_code,
        feature_a, feature_b, axis, confidence, predictor (names)`` (+ manifold / paper
        angles when included), and the scalars ``mode``, ``model_version``.

        ``binary=True`` sends and receives npz (float64, no JSON round trip); False uses JSON.
        A batch that names compound objects returns the summary columns (``colliding, point,
        normal, depth, cluster_size, predictor``) and ``contacts`` (ragged part contacts,
        ``offsets`` (N + 1,); :func:`contacts_of` gives one row's) in both encodings.
        """
        options = {"mode": mode, "include": list(include) or None,
                   "euler_convention": euler_convention}
        options = {k: v for k, v in options.items() if v is not None}
        if binary:
            buffer = io.BytesIO()
            np.savez(buffer, **{k: np.asarray(v) for k, v in columns.items()})
            query = urllib.parse.urlencode(options, doseq=True)
            status, headers, data = self.request(
                "POST", "/v1/contact/batch" + (f"?{query}" if query else ""),
                buffer.getvalue(), {"Content-Type": NPZ, "Accept": NPZ})
            self._check(status, headers, data)
            with np.load(io.BytesIO(data), allow_pickle=False) as npz:
                raw = {k: npz[k] for k in npz.files}
            if "contact_offsets" in raw:
                return _compound(raw)
            out = {k: v for k, v in raw.items() if not k.endswith(("_code", "_names"))
                   and k not in ("mode", "model_version")}
            out["contact_type_code"] = raw["contact_type_code"]
            out["contact_type"] = raw["contact_type_names"][raw["contact_type_code"]]
            out["predictor"] = raw["predictor_names"][raw["predictor_code"]]
            out["mode"], out["model_version"] = str(raw["mode"]), str(raw["model_version"])
            return out
        body = self._json("POST", "/v1/contact/batch", dict(columns) | options)
        if "contacts" in body:
            ragged = body.pop("contacts")
            return _compound({**body, **{("contact_offsets" if k == "offsets" else
                                          k if k.startswith("contact_") else f"contact_{k}"): v
                                         for k, v in ragged.items()}})
        out = {}
        for key, value in body.items():
            if key in ("mode", "model_version", "n"):
                out[key] = value
            elif key == "paper_angles":
                out[key] = np.array(value, dtype=np.float64)  # null -> NaN
            else:
                out[key] = np.asarray(value)
        unique, inverse = np.unique(out["contact_type"], return_inverse=True)
        codes = np.array([CONTACT_TYPES.index(str(u)) for u in unique], dtype=np.int8)
        out["contact_type_code"] = codes[inverse.reshape(-1)]
        return out


def _compound(raw: dict) -> dict:
    """A compound batch answer: the summary columns as arrays (N rows), and ``contacts``, the
    ragged part contacts as arrays with ``offsets`` (N + 1,); :func:`contacts_of` splits them
    per row."""
    out = {k: (str(v) if k in ("mode", "model_version") else v if k == "n" else np.asarray(v))
           for k, v in raw.items() if not k.startswith("contact_")}
    out["contacts"] = {("offsets" if k == "contact_offsets" else k.removeprefix("contact_")
                        if k != "contact_type" else k): np.asarray(v)
                       for k, v in raw.items() if k.startswith("contact_")}
    return out


def contacts_of(answer: dict, i: int) -> dict[str, np.ndarray]:
    """The part contacts of row ``i`` of a compound batch answer (columns of its rows)."""
    contacts = answer["contacts"]
    start, stop = int(contacts["offsets"][i]), int(contacts["offsets"][i + 1])
    return {k: v[start:stop] for k, v in contacts.items() if k != "offsets"}


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
