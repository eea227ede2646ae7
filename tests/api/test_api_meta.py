"""GET /api/limits, /api/samples, the page, its plotly.js, the OpenAPI document."""
from api_conftest import api, client, db_path  # noqa: F401
from app.config import Limits
from pneucore.data.samples import list_samples


def test_limits_are_the_settings_limits(client):
    r = client.get("/api/limits")
    assert r.status_code == 200
    assert {k: v for k, v in r.json().items() if k in Limits().to_dict()} == Limits().to_dict()
    # the deployment settings (README: Running on a shared server)
    assert r.json()["allowed_hosts"] == ["localhost", "127.0.0.1", "::1"]
    assert r.json()["token_required"] is False
    for key in ("max_duration", "max_samples", "max_upload_bytes", "max_experiments",
                "max_analysis_samples", "job_time_limit"):
        assert r.json()[key] > 0


def test_limits_follow_custom_settings(db_path):
    with api(db_path, max_duration=2.5, max_samples=1234, job_time_limit=0.5) as c:
        d = c.get("/api/limits").json()
    assert (d["max_duration"], d["max_samples"], d["job_time_limit"]) == (2.5, 1234, 0.5)


def test_samples_manifest(client):
    r = client.get("/api/samples")
    assert r.status_code == 200
    assert r.json() == list_samples()
    assert {"clean", "piston-leak"} <= {s["id"] for s in r.json()}


def test_page_is_served(client):
    r = client.get("/")
    assert r.status_code == 200, r.text[:300]
    assert r.headers["content-type"].startswith("text/html")


def test_local_plotly_js_is_served(client):
    r = client.get("/static/plotly.min.js")
    assert r.status_code == 200
    assert "javascript" in r.headers["content-type"]
    assert len(r.content) > 100_000  # the real minified bundle, not a stub


def test_every_script_of_the_page_is_served_and_every_page_script_is_named(client):
    """The page is classic scripts, one per view plus app.js (shared state, helpers, wiring): each
    one index.html names is served as JavaScript under the same CSP (no inline script), app.js
    comes after the views it wires at load, and no static/*.js is left out of the page."""
    import re
    from pathlib import Path
    html = client.get("/").text
    names = re.findall(r'<script src="/static/([^"]+)"', html)
    assert "<script>" not in html and len(names) == len(re.findall(r"<script\b", html))
    for name in names:
        r = client.get(f"/static/{name}")
        assert r.status_code == 200 and "javascript" in r.headers["content-type"], name
        assert "'unsafe-inline'" not in r.headers["content-security-policy"].split("script-src")[1].split(";")[0]
    static = Path(__file__).resolve().parents[2] / "static"
    # swagger-init.js belongs to the API docs page (app/main.py), not to this page; plotly.min.js
    # is served from the plotly package, not kept in static/
    assert set(names) - {"plotly.min.js"} == {p.name for p in static.glob("*.js")} - {"swagger-init.js"}
    views = ("model.js", "simulation.js", "datasets.js", "compare.js", "history.js", "diagnosis.js", "study.js")
    assert all(names.index(v) < names.index("app.js") for v in views)
    # the model draft (static/draft.js) is there before any view script loads a model
    assert names.index("draft.js") < min(names.index(v) for v in views)


def test_openapi_documents_every_route_and_units(client):
    r = client.get("/openapi.json")
    assert r.status_code == 200
    doc = r.json()
    for path in ("/api/presets", "/api/presets/{name}", "/api/effects", "/api/simulate",
                 "/api/simulate/heat-models", "/api/compare", "/api/calibrate", "/api/diagnose",
                 "/api/datasets", "/api/datasets/{dataset_id}", "/api/sessions",
                 "/api/sessions/{session_id}", "/api/sessions/{session_id}/versions",
                 "/api/jobs/diagnose", "/api/jobs/calibrate", "/api/jobs/compare",
                 "/api/jobs/{job_id}", "/api/limits", "/api/samples"):
        assert path in doc["paths"], path
    schemas = doc["components"]["schemas"]
    # every physical input field says its unit in brackets
    for name in ("JackIn", "SourceIn", "HeatIn", "FrictionSetIn", "GasIn", "SolverIn", "InitialIn"):
        for field, spec in schemas[name]["properties"].items():
            assert "[" in spec.get("description", ""), (name, field)


def test_start_up_objects_are_frozen_out_of_full_collections_while_the_app_runs(db_path):
    # app.main._freeze_start_up_objects: once the core is loaded, the objects of the start-up
    # leave the collector's full collections (one took 0.1 s); the app's shutdown undoes it
    import gc
    import time

    seen = []
    with api(db_path) as c:
        t0 = time.monotonic()
        while gc.get_freeze_count() == 0 and time.monotonic() - t0 < 60:   # a bound on a hang
            time.sleep(0.01)
        seen.append(gc.get_freeze_count())
        assert c.get("/api/limits").status_code == 200
    assert seen[0] > 10_000   # the modules, the app, the compiled core's objects
    assert gc.get_freeze_count() == 0
