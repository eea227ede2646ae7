"""The circuit through the API (issue 23, issue 28 item 3): mounting angle, return spring,
flow controls, silencer and chamber-B modes accepted by POST /api/simulate, and every bad
value a 422 naming the field and its unit."""
import pytest

from api_conftest import assert_field_error, client, db_path, model, scenario, sim_body  # noqa: F401

G = 9.80665     # standard gravity [m/s^2]


def _three_way(**changes):
    m = model("paper-3way")
    m["valve"]["b_chamber_pressure"] = None
    for k, v in changes.items():
        m["valve"][k] = v
    return m


@pytest.mark.parametrize("body,field,msg", [
    (lambda: model(**{"jack.mounting_angle": 91.0}), "model.jack.mounting_angle", "[deg]"),
    (lambda: model(**{"jack.mounting_angle": -90.5}), "model.jack.mounting_angle", "[deg]"),
    (lambda: model(effects={"return_spring": {"rate": -1.0}}), "model.effects.return_spring.rate",
     "[N/m]"),
    (lambda: model(effects={"meter_out_throttle": {"C_a": -1e-9}}),
     "model.effects.meter_out_throttle.C_a", "[m^3/(s Pa)]"),
    (lambda: model("paper-3way", effects={"meter_out_throttle": {"C_b": 1e-9}}),
     "model.effects.meter_out_throttle.C_b", "no port B"),
    (lambda: model("paper-3way", effects={"meter_in_throttle": {"C_a": 0.0}}),
     "model.effects.meter_in_throttle.C_b", "[m^3/(s Pa)]"),
    (lambda: model(effects={"tubing": {"length_a": -2.0}}), "model.effects.tubing.length_a", "[m]"),
    (lambda: model(effects={"tubing": {"diameter_a": 0.0}}), "model.effects.tubing.diameter_a",
     "[m]"),
    (lambda: model("paper-3way", effects={"tubing": {"length_a": 1.0}}),
     "model.effects.tubing.length_b", "no port B"),
    (lambda: model(effects={"tubing": {"segments": 0}}), "model.effects.tubing.segments", "[-]"),
    (lambda: model(effects={"tubing": {"segments": 33}}), "model.effects.tubing.segments", "[-]"),
    (lambda: model(effects={"tubing": {"segments": 2.5}}), "model.effects.tubing.segments",
     "whole number"),
    (lambda: model(**{"valve.b_chamber": "closed"}), "model.valve.b_chamber", "3/2"),
    (lambda: _three_way(b_chamber="restriction"), "model.valve.b_chamber_conductance",
     "[m^3/(s Pa)]"),
    (lambda: _three_way(b_chamber="vented", b_chamber_pressure=2e5),
     "model.valve.b_chamber_pressure", "[Pa]"),
    (lambda: _three_way(b_chamber="closed", b_chamber_conductance=1e-9),
     "model.valve.b_chamber_conductance", "restriction"),
])
def test_bad_circuit_input_is_a_422_naming_field_and_unit(client, body, field, msg):
    r = client.post("/api/simulate", json=sim_body(body()))
    assert_field_error(r, field, msg_contains=msg)


def test_a_line_in_segments_with_end_cushions_simulates(client):
    """Once refused (the needle then acted at the valve's end of the line): the needle now sits
    at the line's chamber end, and the answer reports the impacts against the capacity."""
    m = model(effects={"tubing": {"length_a": 0.5, "length_b": 0.5, "segments": 2},
                       "end_cushion": {"length_a": 0.015, "length_b": 0.015, "C_a": 4e-9,
                                       "C_b": 4e-9, "capacity": 0.5}})
    s = {"duration": 0.6, "sample_period": 1e-3, "x0": 0.0, "locked": False,
         "command": [[0.0, 0.0], [0.02, 1.0], [0.3, -1.0]]}
    r = client.post("/api/simulate", json=sim_body(m, s))
    assert r.status_code == 200, r.text[:500]
    d = r.json()
    stops = [e for e in d["events"] if e["kind"] == "stop"]
    assert {e["mode"] for e in stops} == {"stop@stroke", "stop@0"}   # out and back, to both ends


def test_unknown_chamber_b_mode_is_refused_by_the_schema(client):
    r = client.post("/api/simulate", json=sim_body(_three_way(b_chamber="bogus")))
    assert r.status_code == 422
    assert r.json()["detail"][0]["loc"][-1] == "b_chamber"


def test_initial_p_b_of_a_held_chamber_b_is_refused_with_its_unit(client):
    s = scenario("paper-fig9-switching", **{"initial.p_b": 2e5})
    assert_field_error(client.post("/api/simulate", json=sim_body(_three_way(), s)),
                       "scenario.initial.p_b", msg_contains="[Pa]")


def test_spring_angle_and_closed_chamber_b_simulate(client):
    """A vertical spring-return cylinder with chamber B closed: answered, and the static
    force at rest (locked at x0, before any flow) carries the spring and the weight."""
    m = _three_way(b_chamber="closed")
    m["jack"]["mounting_angle"] = 90.0
    m["effects"] = {"return_spring": {"rate": 1000.0, "preload": 30.0},
                    "meter_in_throttle": {"C_a": 3e-9, "C_b": 0.0},
                    "exhaust_silencer": {"C": 1e-8}}
    s = scenario("paper-fig9-switching")
    r = client.post("/api/simulate", json=sim_body(m, s))
    assert r.status_code == 200, r.text[:500]
    d = r.json()
    x0 = d["series"]["x"][0]
    # both chambers at ambient at t = 0 on a jack with equal rods: pressures cancel, the net
    # force is -(F0 + k x0) - m g (to float rounding of the pressure terms)
    expected = -(30.0 + 1000.0 * x0) - m["jack"]["moving_mass"] * G
    assert d["series"]["net_force"][0] == pytest.approx(expected, abs=1e-6)
    assert len(set(d["series"]["p_b"])) > 1        # chamber B is a gas volume, not held
