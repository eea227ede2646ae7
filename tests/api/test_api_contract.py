"""The OpenAPI document types every JSON answer, and the answers match it (issue 11, item 5)."""
import pytest

from api_conftest import api  # noqa: F401  (fixture factory)
from pneucore.study.definition import Study
from pneucore.description.validation import FieldError


@pytest.fixture
def client(tmp_path):
    from api_conftest import api as make
    with make(tmp_path / "contract.sqlite3") as c:
        yield c


def test_every_json_answer_has_a_schema(client):
    doc = client.get("/openapi.json").json()
    untyped = []
    for path, ops in doc["paths"].items():
        for method, op in ops.items():
            for code, resp in op["responses"].items():
                content = resp.get("content", {})
                if code.startswith("2") and "application/json" in content \
                        and not content["application/json"].get("schema"):
                    untyped.append(f"{method.upper()} {path} {code}")
    assert untyped == []


@pytest.mark.parametrize("path", ["/api/presets", "/api/presets/paper-4way", "/api/effects",
                                  "/api/limits", "/api/samples", "/api/heat-models",
                                  "/api/sessions", "/api/studies", "/api/studies/clusters"])
def test_catalog_answers_validate_against_their_models(client, path):
    # FastAPI validates a returned dict against the route's response model: a mismatch is a 500
    r = client.get(path)
    assert r.status_code == 200, r.text[:400]


def test_a_session_answer_keeps_its_versions(client):
    model = client.get("/api/presets/paper-4way").json()
    s = client.post("/api/sessions", json={"name": "s", "model": model, "experiments": []}).json()
    assert [v["label"] for v in s["versions"]] == ["base"]
    assert s["versions"][0]["model"]["jack"]["bore"] == model["jack"]["bore"]


def test_limits_document_every_field_of_the_limits_dataclass(client):
    from dataclasses import fields

    from app.config import Limits
    doc = client.get("/openapi.json").json()
    props = doc["components"]["schemas"]["LimitsResponse"]["properties"]
    assert {f.name for f in fields(Limits)} <= set(props)


def test_a_study_json_may_name_presets():
    study = Study.from_dict({"model": "paper-4way", "scenario": "paper-fig10-pulses",
                             "parameters": {"friction.extend.fc0": {"distribution": "uniform",
                                                                    "min": 4, "max": 16}},
                             "samples": 3})
    assert study.n_runs == 3
    assert study.model.jack.bore == 0.032      # the paper-4way preset's bore [m]
    with pytest.raises(FieldError) as e:
        Study.from_dict({"model": "paper-4way", "scenario": "nosuch", "parameters": {}})
    assert e.value.path == "scenario" and "paper-fig10-pulses" in e.value.detail
