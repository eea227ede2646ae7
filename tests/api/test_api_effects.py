"""GET /api/effects: the catalog, and every effect usable through /api/simulate."""
import math

import pytest

from api_conftest import assert_field_error, client, db_path, model, scenario  # noqa: F401
from pneucore.description.effects import EFFECTS


def _plain_model():
    """paper-4way with nothing any catalog effect would duplicate (so each one applies)."""
    m = model()
    m["heat"]["model"] = "isothermal"
    m["friction"] = {"extend": {"fc0": 10.0, "kv0": 30.0}}
    return m


def test_catalog_lists_every_effect_once(client):
    r = client.get("/api/effects")
    assert r.status_code == 200
    names = [e["name"] for e in r.json()]
    assert sorted(names) == sorted(EFFECTS)
    assert len(names) == len(set(names))


def test_every_effect_has_documented_parameters_with_units(client):
    for e in client.get("/api/effects").json():
        assert e["description"].strip() and e["signature"].strip(), e["name"]
        assert e["parameters"], e["name"]
        for p in e["parameters"]:
            where = (e["name"], p["name"])
            assert isinstance(p["unit"], str) and p["unit"].strip(), where
            assert p["description"].strip(), where
            assert math.isfinite(p["min"]) and math.isfinite(p["max"]) and p["min"] < p["max"], where
            assert p["min"] <= p["default"] <= p["max"], where
        assert set(e["fit_params"]) <= {p["name"] for p in e["parameters"]}, e["name"]
        assert set(e["observable_in"]) <= {"locked", "free"}, e["name"]


def test_catalog_matches_library(client):
    for e in client.get("/api/effects").json():
        assert e == EFFECTS[e["name"]].to_dict()


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_each_effect_simulates_with_its_defaults(client, name):
    cat = {e["name"]: e for e in client.get("/api/effects").json()}
    m = _plain_model()
    if name == "wall_heat_capacity":   # walls with a capacity need a gas that is not isothermal
        m["heat"]["model"] = "adiabatic"
    m["effects"] = {name: {p["name"]: p["default"] for p in cat[name]["parameters"]}}
    r = client.post("/api/simulate", json={"model": m, "scenario": scenario(), "series": ["t", "x"]})
    assert r.status_code == 200, r.text[:500]
    assert r.json()["status"] == 0


def test_effect_parameter_out_of_bounds_names_the_parameter(client):
    m = _plain_model()
    m["effects"] = {"piston_leakage": {"conductance": -1.0}}
    assert_field_error(client.post("/api/simulate", json={"model": m, "scenario": scenario()}),
                       "model.effects.piston_leakage.conductance")


def test_unknown_effect_and_parameter_named(client):
    m = _plain_model()
    m["effects"] = {"warp_drive": {}}
    assert_field_error(client.post("/api/simulate", json={"model": m, "scenario": scenario()}),
                       "model.effects.warp_drive", msg_contains="unknown effect")
    m["effects"] = {"piston_leakage": {"bogus": 1.0}}
    assert_field_error(client.post("/api/simulate", json={"model": m, "scenario": scenario()}),
                       "model.effects.piston_leakage.bogus", msg_contains="conductance")


def test_effect_duplicating_the_base_model_is_refused(client):
    m = model()  # paper-4way already has convective exchange
    m["effects"] = {"heat_exchange": {"h": 25.0}}
    assert_field_error(client.post("/api/simulate", json={"model": m, "scenario": scenario()}),
                       "model.effects.heat_exchange", msg_contains="convective")


@pytest.mark.parametrize("cushion, field, msg", [
    ({"length_b": 0.3}, "model.effects.end_cushion.length_b", ("longer than the stroke", "[m]")),
    ({"length_a": -0.005}, "model.effects.end_cushion.length_a", ("[m]",)),
    ({"length_a": 0.2, "length_b": 0.1}, "model.effects.end_cushion.length_b", ("overlap", "[m]")),
])
def test_a_bad_end_cushion_is_a_422_naming_the_field_and_unit(client, cushion, field, msg):
    m = model()
    m["effects"] = {"end_cushion": cushion}
    r = client.post("/api/simulate", json={"model": m, "scenario": scenario()})
    assert_field_error(r, field, msg_contains=msg)


def test_stop_events_carry_the_impact_velocity_and_the_stroke_its_energy(client):
    m = model()
    m["effects"] = {"end_cushion": {"length_a": 0.015, "length_b": 0.015, "C_a": 4e-9,
                                    "C_b": 4e-9, "capacity": 0.2}}
    s = scenario(**{"x0": 0.0, "duration": 0.5,
                    "command": [[0.0, 0.0], [0.05, 1.0]], "command_interpolation": "hold"})
    d = client.post("/api/simulate", json={"model": m, "scenario": s})
    assert d.status_code == 200, d.text[:500]
    d = d.json()
    stops = [e for e in d["events"] if e["kind"] == "stop"]
    assert stops and all(math.isfinite(e["v"]) and e["v"] > 0.0 for e in stops)
    st = d["stats"]["stroke"]
    assert len(st["impacts"]) == len(stops)
    ext = [s for s in st["strokes"] if s["direction"] == "extend"][0]
    assert ext["end_speed"] == max(e["v"] for e in stops)
    assert ext["cushion_capacity"] == 0.2
    assert ext["energy_ratio"] == pytest.approx(ext["end_energy"] / 0.2, rel=1e-12)
