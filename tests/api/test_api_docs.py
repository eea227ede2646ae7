"""/docs and /redoc offline, response models and request examples in the OpenAPI (issue 11 item 5)."""
import re

import pytest

from api_conftest import client, db_path  # noqa: F401


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_docs_pages_use_only_local_assets(client, page):
    r = client.get(page)
    assert r.status_code == 200
    urls = re.findall(r'(?:src|href|url)\s*[=:]\s*["\']([^"\']+)["\']', r.text)
    assert urls, r.text
    for u in urls:
        assert u.startswith("/"), f"{page} loads {u} from outside the service"
        assert client.get(u).status_code == 200, u


def test_favicon(client):
    assert client.get("/favicon.ico").status_code == 200


def test_analysis_responses_are_documented_models(client):
    spec = client.get("/openapi.json").json()
    for path in ("/api/simulate", "/api/compare", "/api/calibrate", "/api/diagnose",
                 "/api/simulate/heat-models"):
        schema = spec["paths"][path]["post"]["responses"]["200"]["content"]["application/json"]["schema"]
        assert "$ref" in schema, (path, schema)
    for path in ("/api/simulate", "/api/compare"):
        assert "text/csv" in spec["paths"][path]["post"]["responses"]["200"]["content"]
    comp = spec["components"]["schemas"]["CompareResponse"]["properties"]
    assert "fraction" in comp["overall"]["description"] and "not percent" in comp["overall"]["description"]
    assert "fractions" in spec["info"]["description"]


@pytest.mark.parametrize("name", ["SimulateRequest", "CompareRequest", "CalibrateRequest",
                                  "DiagnoseRequest", "StudyRequest"])
def test_request_examples_are_valid_requests(client, name):
    import app.schemas as schemas
    spec = client.get("/openapi.json").json()
    examples = spec["components"]["schemas"][name]["examples"]
    assert examples
    getattr(schemas, name).model_validate(examples[0])   # the example passes its own schema


def test_simulate_example_runs(client):
    spec = client.get("/openapi.json").json()
    ex = spec["components"]["schemas"]["SimulateRequest"]["examples"][0]
    r = client.post("/api/simulate", json=ex)
    assert r.status_code == 200 and set(r.json()["series"]) == set(ex["series"])
