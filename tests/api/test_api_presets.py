"""GET /api/presets, /api/presets/{name}."""
import pytest

from api_conftest import client, db_path, sim_body  # noqa: F401
from pneucore.description.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset


def test_list_names_every_preset_with_a_description(client):
    r = client.get("/api/presets")
    assert r.status_code == 200
    d = r.json()
    assert [m["name"] for m in d["models"]] == list(MODEL_PRESETS)
    assert [s["name"] for s in d["scenarios"]] == list(SCENARIO_PRESETS)
    for item in d["models"] + d["scenarios"]:
        assert isinstance(item["description"], str) and item["description"].strip(), item


@pytest.mark.parametrize("name", list(MODEL_PRESETS))
def test_get_model_preset_is_the_library_preset(client, name):
    r = client.get(f"/api/presets/{name}")
    assert r.status_code == 200
    assert r.json() == model_preset(name)


@pytest.mark.parametrize("name", list(SCENARIO_PRESETS))
def test_get_scenario_preset_is_the_library_preset(client, name):
    r = client.get(f"/api/presets/{name}")
    assert r.status_code == 200
    got = r.json()
    want = scenario_preset(name)
    # JSON turns the command's (t, u) tuples into lists
    want["command"] = [list(p) for p in want["command"]]
    assert got == want


@pytest.mark.parametrize("model_name,scen_name", [("paper-4way", "paper-fig10-pulses"),
                                                  ("paper-3way", "paper-fig9-switching"),
                                                  ("paper-4way", "paper-fig6-locked-max"),
                                                  ("paper-4way", "paper-fig7-locked-min")])
def test_presets_round_trip_into_simulate(client, model_name, scen_name):
    m = client.get(f"/api/presets/{model_name}").json()
    s = client.get(f"/api/presets/{scen_name}").json()
    r = client.post("/api/simulate", json=sim_body(m, s, series=["t", "x"]))
    assert r.status_code == 200, r.text[:500]
    assert r.json()["status"] == 0


@pytest.mark.parametrize("name", ["nope", "paper-4WAY", "paper-4way.json"])
def test_unknown_preset_404(client, name):
    r = client.get(f"/api/presets/{name}")
    assert r.status_code == 404
    assert name in r.json()["detail"]
