"""GET /v1/models, /healthz, /readyz, /metrics, /docs, /openapi.json."""
from __future__ import annotations

import re

from impactnet.models.scenes import load_scene
from tests.service.conftest import PAIR


def test_models_describes_scene_modes_versions(client):
    response = client.get("/v1/models")
    assert response.status_code == 200
    body = response.json()
    scene = load_scene("quay_crane")
    assert body["scene"]["name"] == "quay_crane" and body["scene"]["hash"] == scene.hash()
    assert body["scene"]["objects"]["container40"] == [12.192, 2.438, 2.591]
    assert ["container40", "spreader"] in body["scene"]["pairs"]
    assert body["modes"]["available"] == ["exact"]
    assert set(body["modes"]["unavailable"]) == {"single", "committee", "auto"}
    assert body["modes"]["default"] == "exact"
    assert body["bundle"] is None
    assert body["model_version"] == f"exact-{body['versions']['impactnet']}+quay_crane." \
        f"{scene.hash()[:12]}"
    assert body["contact_types"][0] == "none" and len(body["feature_names"]) == 27
    assert body["limits"]["max_batch_pairs"] == 100_000
    assert body["limits"]["max_pair_body_bytes"] == 64 * 1024
    assert body["limits"]["max_json_body_bytes"] == 32 * 1024 * 1024
    assert body["includes"] == ["manifold", "paper_angles"]


def test_models_without_scene(make_client):
    body = make_client(scene="").get("/v1/models").json()
    assert body["scene"] is None and body["model_version"].startswith("exact-")
    assert "+" not in body["model_version"]


def test_health_and_ready(client):
    assert client.get("/healthz").json() == {"status": "ok"}
    ready = client.get("/readyz")
    assert ready.status_code == 200
    assert ready.json()["ready"] is True and ready.json()["model_version"].startswith("exact-")


def test_metrics_count_requests_pairs_and_latency(make_client):
    c = make_client()
    for _ in range(3):
        assert c.post("/v2/contact", json=PAIR).status_code == 200
    batch = {"a_size": [2, 2, 2], "a_position": [[0, 0, 0]] * 5, "a_quaternion": [1, 0, 0, 0],
             "b_size": [2, 2, 2], "b_position": [0, 0, 1.9], "b_quaternion": [1, 0, 0, 0]}
    assert c.post("/v2/contact/batch", json=batch).status_code == 200
    assert c.post("/v2/contact", json={"a": {}}).status_code == 422
    assert c.get("/v1/unknown").status_code == 404
    response = c.get("/metrics")
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("text/plain")
    text = response.text

    def value(pattern: str) -> float:
        match = re.search(re.escape(pattern) + r" ([0-9.e+]+)", text)
        assert match, pattern
        return float(match.group(1))

    assert value('impactnet_http_requests_total{method="POST",route="/v2/contact",'
                 'status="200"}') == 3
    assert value('impactnet_http_requests_total{method="POST",route="/v2/contact",'
                 'status="422"}') == 1
    assert value('impactnet_http_requests_total{method="GET",route="<unmatched>",'
                 'status="404"}') == 1
    assert value('impactnet_pairs_scored_total{mode="exact",predictor="exact"}') == 8
    assert value('impactnet_http_request_duration_seconds_count{method="POST",'
                 'route="/v2/contact"}') == 4
    assert value("impactnet_batch_pairs_count") == 1
    assert value("impactnet_ready") == 1
    assert value("impactnet_auto_fallback_rate") == 0
    assert 'impactnet_model_info{model_version="exact-' in text


def test_docs_and_openapi(client):
    assert client.get("/docs").status_code == 200
    schema = client.get("/openapi.json").json()
    paths = schema["paths"]
    assert {"/v2/contact", "/v2/contact/batch", "/v1/models", "/healthz", "/readyz",
            "/metrics"} <= set(paths)
    assert not {"/v1/contact", "/v1/contact/batch"} & set(paths)  # 410, not documented
    batch = paths["/v2/contact/batch"]["post"]
    assert set(batch["requestBody"]["content"]) == {"application/json", "application/x-npz"}
    assert "BatchRequest" in schema["components"]["schemas"]
    assert "Binary layout" in batch["description"]
    body = schema["components"]["schemas"]["Body"]
    assert body["additionalProperties"] is False


def test_models_names_the_conventions_and_the_point_rule(client):
    from impactnet.models.contacts import POINT_RULE, POINT_RULE_VERSION

    response = client.get("/v1/models")
    assert response.status_code == 200
    conventions = response.json()["conventions"]
    assert conventions == {"point": {"rule": POINT_RULE, "version": POINT_RULE_VERSION},
                           "normal": "from A towards B", "units": "metres, radians"}
    assert conventions["point"] == {"rule": "centre-of-pressure", "version": 2}
    schema = client.get("/openapi.json").json()["components"]["schemas"]
    assert schema["ModelsResponse"]["properties"]["conventions"]["$ref"].endswith("Conventions")
    assert "centre of pressure" in schema["ContactResponse"]["properties"]["point"][
        "description"]
    assert "deepest first" in schema["Manifold"]["properties"]["depths"]["description"]
