"""POST /api/linearize and closed-loop POST /api/simulate (issue 42)."""
import math

from api_conftest import api, assert_field_error, client, db_path  # noqa: F401
from pneucore import model_preset


def test_linearize_answers_the_contract(client):
    r = client.post("/api/linearize", json={"model": model_preset("paper-4way"),
                                            "operating_point": {"x": 0.1}})
    assert r.status_code == 200, r.text
    ans = r.json()
    for k in ("natural_frequency", "damping", "poles", "A", "B", "C", "D", "states"):
        assert k in ans
    n = len(ans["states"])
    assert len(ans["A"]) == n and len(ans["B"]) == n and len(ans["C"][0]) == n
    assert ans["operating_point"]["x"] == 0.1
    assert ans["operating_point"]["p_a"] == ans["operating_point"]["p_b"]   # equilibrium
    assert 1.0 < ans["natural_frequency"] < 100.0


def test_linearize_outside_the_stroke_is_a_422_naming_the_field(client):
    r = client.post("/api/linearize", json={"model": model_preset("paper-4way"),
                                            "operating_point": {"x": 0.5}})
    assert_field_error(r, "operating_point.x")
    assert "[m]" in r.text or " m " in r.text


def servo():
    from pneucore.control.models import servo_model
    return servo_model()


def closed(controller, **scen):
    return {"model": servo(), "scenario": {"duration": 0.5, "sample_period": 0.001, "x0": 0.1,
                                           "initial": {"p_a": 5.3e5, "p_b": 5.3e5},
                                           "controller": controller, **scen}}


def test_simulate_with_a_controller_answers_x_ref_and_control_stats(client):
    r = client.post("/api/simulate", json=closed(
        {"kind": "pid", "gains": {"kp": 15.0, "ki": 0.0, "kd": 0.0},
         "setpoint": [[0, 0.1], [0.05, 0.11]]}))
    assert r.status_code == 200, r.text
    ans = r.json()
    assert ans["units"]["x_ref"] == "m"
    assert ans["series"]["x_ref"][-1] == 0.11
    ctl = ans["stats"]["control"]
    for k in ("rise_time", "settling_time", "overshoot", "steady_state_error"):
        assert k in ctl
    assert ctl["rise_time"] > 0 and ctl["overshoot"] >= 0
    assert max(abs(u) for u in ans["series"]["u"]) <= 1.0     # clipped to the valve's range


def test_unstable_gains_are_a_422_naming_the_gains(client):
    r = client.post("/api/simulate", json=closed(
        {"kind": "pid", "gains": {"kp": 1500, "ki": 5000}, "setpoint": [[0, 0.1], [0.05, 0.15]]},
        duration=1.0))
    assert_field_error(r, "scenario.controller.gains", msg_contains="unstable")


def test_bad_gains_and_setpoints_are_422s_naming_field_and_unit(client):
    r = client.post("/api/simulate", json=closed({"kind": "pid", "gains": {"kp": "inf"},
                                                  "setpoint": [[0, 0.1]]}))
    assert r.status_code == 422
    r = client.post("/api/simulate", json=closed({"kind": "pid", "gains": {},
                                                  "setpoint": [[0, 0.1]]}))
    assert_field_error(r, "scenario.controller.gains.kp", msg_contains="1/m")
    r = client.post("/api/simulate", json=closed({"kind": "pid", "gains": {"kp": 10},
                                                  "setpoint": [[0, 0.4]]}))
    assert_field_error(r, "scenario.controller.setpoint[0][1]", msg_contains="stroke")
    m = model_preset("paper-3way")
    r = client.post("/api/simulate", json={"model": m, "scenario": {
        "duration": 0.1, "x0": 0.1, "controller": {"kind": "sliding_mode", "gains": {"lambda": 10},
                                                   "setpoint": [[0, 0.1]]}}})
    assert_field_error(r, "scenario.controller.kind", msg_contains="3/2")
    body = closed({"kind": "pid", "gains": {"kp": 10}, "setpoint": [[0, 0.1]]})
    body["scenario"]["command"] = [[0, 0.5]]
    assert_field_error(client.post("/api/simulate", json=body), "scenario.command")


def test_controllers_are_listed_with_their_gains_units(client):
    r = client.get("/api/controllers")
    assert r.status_code == 200
    kinds = {c["kind"]: c for c in r.json()["controllers"]}
    assert {"pid", "sliding_mode", "onoff", "pva", "force_pid"} <= set(kinds)
    assert kinds["pid"]["gains"]["kp"]["unit"] == "1/m"
    assert "3/2" in kinds["onoff"]["valves"] and "3/2" not in kinds["pid"]["valves"]


def _study():
    return {"model": servo(), "parameters": {"jack.moving_mass": {"grid": [1.0, 4.0]}},
            "scenario": {"duration": 0.5, "x0": 0.1, "initial": {"p_a": 5.3e5, "p_b": 5.3e5},
                         "controller": {"kind": "pid", "gains": {"kp": 15},
                                        "setpoint": [[0, 0.1], [0.05, 0.11]]}}}


def test_tuning_runs_as_a_job_and_bad_studies_are_422s_now(client):
    from api_conftest import wait_job
    r = client.post("/api/jobs/tune-controller", json={"study": _study(), "gains": {"kp": [5, 10]},
                                                        "objective": "overshoot"})
    assert r.status_code == 202, r.text
    job, _ = wait_job(client, r.json()["id"])
    assert job["status"] == "done", job
    assert job["result"]["best"]["gains"]["kp"] in (5, 10)
    bad = _study()
    bad["scenario"]["controller"]["gains"] = {"kp": -1}
    assert_field_error(client.post("/api/jobs/control-study", json={"study": bad}),
                       "scenario.controller.gains.kp")


def test_control_study_job_runs_on_the_study_pool_with_a_specification(client):
    from api_conftest import wait_job
    r = client.post("/api/jobs/control-study",
                    json={"study": _study(), "specification": {"overshoot": 10.0}})
    assert r.status_code == 202, r.text
    job, _ = wait_job(client, r.json()["id"])
    assert job["status"] == "done", job
    res = job["result"]
    assert res["meets"] == [True, True] and res["summary"]["meets_fraction"] == 1.0
    assert res["units"]["overshoot"] == "-"
    assert_field_error(client.post("/api/jobs/control-study",
                                   json={"study": _study(), "specification": {"overshoot": -1}}),
                       "specification.overshoot", msg_contains="[-]")


def test_sensed_position_in_the_answer_and_bad_sensor_values_are_422s(client):
    body = closed({"kind": "pid", "gains": {"kp": 15}, "setpoint": [[0, 0.1], [0.05, 0.11]],
                   "seed": 3})
    body["model"]["effects"] = {"sensor_lag": {"time_constant": 0.0,
                                               "position_resolution": 1e-4}}
    r = client.post("/api/simulate", json=body)
    assert r.status_code == 200, r.text
    ans = r.json()
    assert ans["units"]["x_sensed"] == "m" and ans["units"]["x_ref"] == "m"
    assert len(ans["series"]["x_sensed"]) == len(ans["series"]["x"])
    for param, value, unit in (("position_resolution", -1e-4, "[m]"),
                               ("position_noise", "inf", "[m]"),
                               ("pressure_noise", -5.0, "[Pa]")):
        body["model"]["effects"] = {"sensor_lag": {param: value}}
        assert_field_error(client.post("/api/simulate", json=body),
                           f"model.effects.sensor_lag.{param}", msg_contains=unit)
    body["model"]["effects"] = {}
    body["scenario"]["controller"]["seed"] = -1
    assert_field_error(client.post("/api/simulate", json=body), "scenario.controller.seed")


def test_estimated_rates_and_sensed_pressures_in_the_answer_and_their_422s(client):
    # the laws read the velocity and acceleration estimated from the sensed position: the
    # answer carries them (v_est [m/s], a_est [m/s^2]); ideal_rates drops them; quantised
    # transducers add the pressures read (p_a_sensed, p_b_sensed [Pa])
    body = closed({"kind": "pva", "gains": {"kp": 15, "kv": 0.05},
                   "setpoint": [[0, 0.1], [0.05, 0.11]], "rate_filter": 0.004})
    body["model"]["effects"] = {"sensor_lag": {"time_constant": 0.0,
                                               "pressure_resolution": 1000.0}}
    r = client.post("/api/simulate", json=body)
    assert r.status_code == 200, r.text
    ans = r.json()
    assert ans["units"]["v_est"] == "m/s" and ans["units"]["a_est"] == "m/s^2"
    assert ans["units"]["p_a_sensed"] == "Pa" and ans["units"]["p_b_sensed"] == "Pa"
    assert len(ans["series"]["v_est"]) == len(ans["series"]["x"])
    # a 1 kPa grid: every pressure read is a whole number of kPa (to the JSON's rounding)
    pa = [p for p in ans["series"]["p_a_sensed"] if p is not None]
    assert max(abs(p / 1000.0 - round(p / 1000.0)) for p in pa) < 1e-9
    body["scenario"]["controller"]["ideal_rates"] = True
    ans = client.post("/api/simulate", json=body).json()
    assert "v_est" not in ans["series"] and "a_est" not in ans["series"]
    for field, value, unit in (("rate_filter", -0.001, "[s]"), ("ideal_rates", "no", "[-]")):
        bad = closed({"kind": "pva", "gains": {"kp": 15}, "setpoint": [[0, 0.1]], field: value})
        assert_field_error(client.post("/api/simulate", json=bad),
                           f"scenario.controller.{field}", msg_contains=unit)
    body["model"]["effects"] = {"sensor_lag": {"pressure_resolution": -1.0}}
    assert_field_error(client.post("/api/simulate", json=body),
                       "model.effects.sensor_lag.pressure_resolution", msg_contains="[Pa]")
