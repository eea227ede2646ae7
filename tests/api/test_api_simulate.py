"""POST /api/simulate and /api/simulate/heat-models: results, units, filters, every 422 path,
the API limits, and concurrent requests (shared TestClient and a real uvicorn server)."""
import json
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pytest

from api_conftest import (api, assert_field_error, client, db_path, live_server, model,  # noqa: F401
                          scenario, sim_body)
from pneucore import simulate as lib_simulate
from pneucore.description.model import Model
from pneucore.description.scenario import Scenario

DEFAULT_SERIES = {"t", "u", "p_a", "p_b", "T_a", "T_b", "m_a", "m_b", "x", "v", "a", "q_a", "q_b",
                  "friction", "mode", "u_eff", "p_supply", "q_supply", "net_force"}
SI_UNITS = {"t": "s", "p_a": "Pa", "p_b": "Pa", "T_a": "K", "T_b": "K", "x": "m", "v": "m/s",
            "a": "m/s^2", "m_a": "kg", "m_b": "kg", "q_a": "kg/s", "q_b": "kg/s", "friction": "N",
            "net_force": "N", "p_supply": "Pa", "u": "-"}


def _samples(s):
    return int(round(s["duration"] / s["sample_period"])) + 1


# ------------------------------------------------------------------------------ success
def test_simulate_returns_all_series_units_events_stats(client):
    s = scenario()
    r = client.post("/api/simulate", json=sim_body(s=s))
    assert r.status_code == 200, r.text[:500]
    d = r.json()
    assert set(d) == {"series", "units", "events", "stats", "status", "message"}
    assert d["status"] == 0 and d["message"] == "ok"
    assert set(d["series"]) == DEFAULT_SERIES
    n = _samples(s)
    assert n == 1001
    for name, values in d["series"].items():
        assert len(values) == n, name
    assert set(d["units"]) == set(d["series"])
    for name, unit in SI_UNITS.items():
        assert d["units"][name] == unit, name
    t = d["series"]["t"]
    assert t[0] == 0.0
    assert t[-1] == pytest.approx(s["duration"], abs=1e-12)  # float grid, exact up to rounding
    # the Fig. 10 scenario: the four pulses each open and close the valve (8 command events)
    kinds = [e["kind"] for e in d["events"]]
    assert kinds.count("command") == 8
    assert {"slip", "stick"} <= set(kinds)
    for e in d["events"]:
        assert 0.0 <= e["t"] <= s["duration"] and e["kind"] and e["mode"]
    # the solver reaches the end time (relative 1e-6: float accumulation of the steps)
    assert d["stats"]["steps"] > 0 and d["stats"]["t_reached"] == pytest.approx(s["duration"], rel=1e-6)
    # physical sanity: pressures between ambient-ish and supply, position inside the stroke
    m = model()
    for p in d["series"]["p_a"] + d["series"]["p_b"]:
        assert 0.5e5 < p <= m["supply"]["pressure"] * 1.001  # 0.1 % allows integrator overshoot
    assert all(0.0 <= x <= m["jack"]["stroke"] for x in d["series"]["x"])


def test_simulate_matches_the_library(client):
    m, s = model(), scenario()
    d = client.post("/api/simulate", json=sim_body(m, s)).json()
    res = lib_simulate(Model.from_dict(m), Scenario.from_dict(s, Model.from_dict(m)))
    for name in ("t", "p_a", "p_b", "x", "v"):
        # same code, same inputs: bit-identical up to the float -> JSON -> float round trip
        np.testing.assert_allclose(d["series"][name], res.series[name], rtol=1e-15, atol=0)
    assert len(d["events"]) == len(res.events)


def test_series_filter(client):
    r = client.post("/api/simulate", json=sim_body(series=["t", "x", "V_a"]))
    assert r.status_code == 200
    d = r.json()
    assert set(d["series"]) == {"t", "x", "V_a"}  # V_a is not a default series but available
    assert set(d["units"]) == {"t", "x", "V_a"}
    assert d["units"]["V_a"] == "m^3"
    assert len(d["series"]["x"]) == 1001


def test_unknown_series_is_named(client):
    assert_field_error(client.post("/api/simulate", json=sim_body(series=["t", "nope"])), "series",
                       msg_contains="nope")


def test_locked_chamber_test_and_3way_model(client):
    d = client.post("/api/simulate", json=sim_body(s=scenario("paper-fig6-locked-max"))).json()
    assert set(d["series"]["x"]) == {0.25}  # locked at x0: exactly constant
    d = client.post("/api/simulate", json=sim_body(model("paper-3way"),
                                                    scenario("paper-fig9-switching"))).json()
    assert d["status"] == 0 and max(d["series"]["x"]) > 0.0


def test_response_is_strict_json(client):
    r = client.post("/api/simulate", json=sim_body(series=["t", "p_a"]))
    json.loads(r.text, parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))


# ------------------------------------------------------------------------------ 422 (pneucore checks)
@pytest.mark.parametrize("path,value,field,msg", [
    ("jack.rod_a", 0.04, "model.jack.rod_a", "bore"),
    ("jack.rod_b", 0.032, "model.jack.rod_b", "bore"),
    ("jack.bore", -0.032, "model.jack.bore", ">"),
    ("jack.stroke", 0.0, "model.jack.stroke", ">"),
    ("supply.pressure", -1.0, "model.supply.pressure", ">"),
    ("valve/ports/P-A/b/0", 1.0, "model.valve.ports.P-A.b[0]", "< 1"),
    ("valve/ports/A-R/b/2", -0.1, "model.valve.ports.A-R.b[2]", ">= 0"),
    ("valve.flow_law", "bogus", "model.valve.flow_law", "iso6358"),
    ("heat.model", "bogus", "model.heat.model", "convective"),
])
def test_invalid_model_names_the_dotted_field(client, path, value, field, msg):
    r = client.post("/api/simulate", json=sim_body(model(**{path: value})))
    assert_field_error(r, field, type="value_error", msg_contains=msg)


@pytest.mark.parametrize("path,value,field,msg", [
    ("x0", 0.3, "scenario.x0", "stroke"),
    ("x0", -0.01, "scenario.x0", ">= 0"),
    ("command", [[0.5, 0.0], [0.2, 0.5]], "scenario.command[1][0]", "decrease"),
    ("command", [[0.0, 0.0], [0.1, 1.5]], "scenario.command[1][1]", "range"),
    ("duration", -1.0, "scenario.duration", ">"),
    ("sample_period", 0.0, "scenario.sample_period", ">"),
])
def test_invalid_scenario_names_the_dotted_field(client, path, value, field, msg):
    r = client.post("/api/simulate", json=sim_body(s=scenario(**{path: value})))
    assert_field_error(r, field, type="value_error", msg_contains=msg)


def test_3way_command_outside_valve_range(client):
    s = scenario("paper-fig9-switching", command=[[0.0, 0.0], [0.2, -0.5]])
    assert_field_error(client.post("/api/simulate", json=sim_body(model("paper-3way"), s)),
                       "scenario.command[1][1]", msg_contains="3/2")


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_number_literal_is_refused_by_field(client, token):
    # NaN is not JSON, but Python's parser accepts the literal: it must not reach the solver
    text = json.dumps(sim_body()).replace('"bore": 0.032', f'"bore": {token}', 1)
    assert token in text
    r = client.post("/api/simulate", content=text, headers={"content-type": "application/json"})
    assert_field_error(r, "model.jack.bore", msg_contains="finite")


# ------------------------------------------------------------------------------ 422 (pydantic)
def _pyd(r, field, type_):
    return assert_field_error(r, field, type=type_)


def test_string_for_number(client):
    _pyd(client.post("/api/simulate", json=sim_body(model(**{"jack.bore": "abc"}))),
         "model.jack.bore", "float_parsing")


def test_missing_required_fields(client):
    _pyd(client.post("/api/simulate", json={"model": model()}), "scenario", "missing")
    _pyd(client.post("/api/simulate", json={"scenario": scenario()}), "model", "missing")
    m = model()
    del m["valve"]["ports"]["P-A"]["C"]
    _pyd(client.post("/api/simulate", json=sim_body(m)), "model.valve.ports.P-A.C", "missing")


def test_wrong_types(client):
    _pyd(client.post("/api/simulate", json=sim_body(model(jack=[1, 2]))), "model.jack", "model_attributes_type")
    _pyd(client.post("/api/simulate", json=sim_body(s=scenario(locked="sometimes"))),
         "scenario.locked", "bool_parsing")
    r = client.post("/api/simulate", json=sim_body(s=scenario(command=[[0.0]])))
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["type"] == "missing" and err["loc"] == ["body", "scenario", "command", 0, 1], err
    _pyd(client.post("/api/simulate", json=sim_body(model(**{"valve.kind": "5/3"}))),
         "model.valve.kind", "literal_error")
    _pyd(client.post("/api/simulate", json=sim_body(s=scenario(solver={"max_steps": 10.5}))),
         "scenario.solver.max_steps", "int_from_float")


def test_pydantic_index_paths_spelled_like_pneucore_paths(client):
    # pneucore names list items "scenario.command[1][0]"; a type error in the same place
    # must name it the same way, so a client can map either error onto its form field
    r = client.post("/api/simulate", json=sim_body(s=scenario(command=[[0.0, 0.0], [0.1]])))
    assert_field_error(r, "scenario.command[1][1]", type="missing")


def test_unknown_fields_are_refused(client):
    _pyd(client.post("/api/simulate", json=sim_body(model(**{"jack.piston_colour": "red"}))),
         "model.jack.piston_colour", "extra_forbidden")
    _pyd(client.post("/api/simulate", json=sim_body(s=scenario(durration=2.0))),
         "scenario.durration", "extra_forbidden")
    _pyd(client.post("/api/simulate", json={**sim_body(), "extra": 1}), "extra", "extra_forbidden")


def test_body_not_json(client):
    r = client.post("/api/simulate", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422
    assert r.json()["detail"][0]["type"] == "json_invalid"


# ------------------------------------------------------------------------------ limits
def _no_simulation(monkeypatch):
    """Make any simulation in the router fail the test: proves a refusal happens up front."""
    import app.routers.simulate as router

    def boom(*a, **k):
        pytest.fail("the simulation ran although the request exceeds the API limits")
    monkeypatch.setattr(router, "simulate", boom)


def test_duration_over_api_limit_refused_up_front(client, monkeypatch):
    lim = client.get("/api/limits").json()
    _no_simulation(monkeypatch)
    s = scenario(duration=lim["max_duration"] * 1.5, sample_period=0.01)
    err = assert_field_error(client.post("/api/simulate", json=sim_body(s=s)), "scenario.duration",
                             msg_contains="limit")
    assert f"{lim['max_duration']:g}" in err["msg"]


def test_samples_over_api_limit_refused_up_front(client, monkeypatch):
    lim = client.get("/api/limits").json()
    _no_simulation(monkeypatch)
    s = scenario(duration=2.0, sample_period=2.0 / lim["max_samples"] / 2)
    assert_field_error(client.post("/api/simulate", json=sim_body(s=s)), "scenario.sample_period",
                       msg_contains=str(lim["max_samples"]))


def test_command_points_over_limit(db_path, monkeypatch):
    with api(db_path, max_command_points=5) as c:
        _no_simulation(monkeypatch)
        s = scenario(command=[[0.1 * i, 0.0] for i in range(6)])
        assert_field_error(c.post("/api/simulate", json=sim_body(s=s)), "scenario.command",
                           msg_contains="limit")


def test_custom_duration_limit(db_path):
    with api(db_path, max_duration=0.5) as c:
        assert_field_error(c.post("/api/simulate", json=sim_body()), "scenario.duration")
        assert c.post("/api/simulate", json=sim_body(s=scenario(duration=0.5))).status_code == 200


def test_small_step_budget_is_a_simulation_error(client):
    r = client.post("/api/simulate", json=sim_body(s=scenario(solver={"max_steps": 10})))
    assert r.status_code == 422
    err = r.json()["detail"][0]
    assert err["type"] == "simulation_error"
    assert err["loc"][:3] == ["body", "scenario", "solver"]
    assert "max_steps" in err["msg"] and "stopped at t =" in err["msg"]


def test_api_step_budget_caps_the_request(db_path):
    # the request asks for the default 2e6 steps; the API's limit (10) wins
    with api(db_path, max_steps=10) as c:
        r = c.post("/api/simulate", json=sim_body(s=scenario(solver={"max_steps": 2_000_000})))
    assert r.status_code == 422 and r.json()["detail"][0]["type"] == "simulation_error"


# ------------------------------------------------------------------------------ heat models
def test_heat_models_returns_three_runs(client):
    r = client.post("/api/simulate/heat-models", json=sim_body(series=["t", "p_a", "T_a"]))
    assert r.status_code == 200, r.text[:500]
    runs = r.json()["runs"]
    assert set(runs) == {"isothermal", "adiabatic", "convective"}
    for name, run in runs.items():
        assert run["status"] == 0, name
        assert set(run["series"]) == {"t", "p_a", "T_a"}
        assert len(run["series"]["p_a"]) == 1001
        assert run["units"]["T_a"] == "K"
    # isothermal keeps the gas at ambient temperature; adiabatic heats it on compression
    assert max(abs(T - 293.15) for T in runs["isothermal"]["series"]["T_a"]) < 1e-6  # exact model
    # ordering only; 294 K = ambient + 0.85 K, far below the tens of kelvin of compression heating
    assert max(runs["adiabatic"]["series"]["T_a"]) > max(runs["convective"]["series"]["T_a"]) > 294.0
    # the convective run is the model's own run
    plain = client.post("/api/simulate", json=sim_body(series=["t", "p_a", "T_a"])).json()
    assert runs["convective"]["series"] == plain["series"]


def test_heat_models_subset(client):
    r = client.post("/api/simulate/heat-models", json={**sim_body(series=["x"]),
                                                       "heat_models": ["adiabatic"]})
    assert r.status_code == 200
    assert list(r.json()["runs"]) == ["adiabatic"]


def test_unknown_heat_model(client):
    r = client.post("/api/simulate/heat-models",
                    json={**sim_body(), "heat_models": ["isothermal", "bogus"]})
    assert_field_error(r, "heat_models[1]", msg_contains="unknown heat model")


def test_heat_models_validates_like_simulate(client):
    assert_field_error(client.post("/api/simulate/heat-models",
                                   json=sim_body(model(**{"jack.rod_a": 0.04}))), "model.jack.rod_a")
    assert_field_error(client.post("/api/simulate/heat-models",
                                   json=sim_body(s=scenario(duration=1000.0, sample_period=0.1))),
                       "scenario.duration")


# ------------------------------------------------------------------------------ concurrency
N_CONCURRENT = 20


def _key(d):
    return json.dumps(d, sort_keys=True)


def test_concurrent_requests_shared_testclient(client):
    body = sim_body()
    ref = client.post("/api/simulate", json=body).json()
    with ThreadPoolExecutor(N_CONCURRENT) as ex:
        rs = list(ex.map(lambda _: client.post("/api/simulate", json=body), range(N_CONCURRENT)))
    assert [r.status_code for r in rs] == [200] * N_CONCURRENT
    assert all(_key(r.json()) == _key(ref) for r in rs)


def test_concurrent_requests_real_server(db_path):
    body = sim_body()
    with live_server(db_path) as url:
        with httpx.Client(base_url=url, timeout=120) as c:  # timeout: a hang bound, not speed
            ref = c.post("/api/simulate", json=body)
            assert ref.status_code == 200
            ref = ref.json()

        def one(i):
            # each worker its own connection; half of them vary the series filter order
            with httpx.Client(base_url=url, timeout=120) as cc:
                return cc.post("/api/simulate", json=body)
        with ThreadPoolExecutor(N_CONCURRENT) as ex:
            rs = list(ex.map(one, range(N_CONCURRENT)))
        assert [r.status_code for r in rs] == [200] * N_CONCURRENT
        assert all(_key(r.json()) == _key(ref) for r in rs)
        # mixed good and bad requests in parallel: each gets its own answer
        bad = sim_body(model(**{"jack.rod_a": 0.04}))

        def mixed(i):
            with httpx.Client(base_url=url, timeout=120) as cc:
                return cc.post("/api/simulate", json=bad if i % 2 else body)
        with ThreadPoolExecutor(N_CONCURRENT) as ex:
            rs = list(ex.map(mixed, range(N_CONCURRENT)))
        for i, r in enumerate(rs):
            if i % 2:
                assert r.status_code == 422 and r.json()["detail"][0]["field"] == "model.jack.rod_a"
            else:
                assert r.status_code == 200 and _key(r.json()) == _key(ref)
