"""A recorded closed-loop test in compare and diagnose (issue 42, item 8): an experiment whose
scenario names the controller it ran under is replayed open loop with its recorded valve
command ``u``, and the answer says so."""
import pytest

from api_conftest import assert_field_error, client, db_path  # noqa: F401

CTL = {"kind": "pid", "gains": {"kp": 15.0, "ki": 0.0, "kd": 0.0},
       "setpoint": [[0, 0.1], [0.05, 0.11]]}


def servo():
    from pneucore.control.models import servo_model
    return servo_model()


@pytest.fixture
def record(client):
    """A closed-loop run of the servo jack, recorded as a rig would: t, u, p_a, p_b, x."""
    r = client.post("/api/simulate", json={
        "model": servo(), "scenario": {"duration": 0.3, "sample_period": 0.001, "x0": 0.1,
                                       "initial": {"p_a": 5.3e5, "p_b": 5.3e5},
                                       "controller": CTL}})
    assert r.status_code == 200, r.text
    s = r.json()["series"]
    return {k: s[k] for k in ("t", "u", "p_a", "p_b", "x")}


def test_compare_replays_a_closed_loop_record_with_its_recorded_command(client, record):
    exp = {"name": "servo step", "scenario": {"x0": 0.1, "controller": CTL},
           "measurement": record}
    r = client.post("/api/compare", json={"model": servo(), "experiments": [exp]})
    assert r.status_code == 200, r.text
    e = r.json()["experiments"][0]
    assert e["command_source"] == "measured"
    cl = e["closed_loop"]
    assert cl["controller"] == "pid" and cl["command_source"] == "measured"
    assert "replayed open loop" in cl["note"] and "recorded valve command" in cl["note"]
    # the record is the model's own run: replayed with its command, it matches
    assert e["overall"] < 1e-3


def test_an_open_loop_record_says_nothing_of_a_closed_loop(client, record):
    exp = {"name": "plain", "scenario": {"x0": 0.1}, "measurement": record}
    r = client.post("/api/compare", json={"model": servo(), "experiments": [exp]})
    assert r.status_code == 200, r.text
    assert "closed_loop" not in r.json()["experiments"][0]


def test_diagnose_says_the_closed_loop_record_was_replayed_open_loop(client, record):
    exp = {"name": "servo step", "scenario": {"x0": 0.1, "controller": CTL},
           "measurement": record}
    r = client.post("/api/diagnose", json={"model": servo(), "experiments": [exp],
                                           "candidates": ["piston_leakage"]})
    assert r.status_code == 200, r.text
    (cl,) = r.json()["closed_loop"]
    assert cl["experiment"] == "servo step" and cl["controller"] == "pid"
    assert "replayed open loop" in cl["note"]


def test_a_closed_loop_record_without_its_command_is_a_422_naming_the_controller(client, record):
    meas = {k: v for k, v in record.items() if k != "u"}
    exp = {"scenario": {"x0": 0.1, "controller": CTL}, "measurement": meas}
    r = client.post("/api/compare", json={"model": servo(), "experiments": [exp]})
    assert_field_error(r, "experiments[0].scenario.controller", msg_contains="'u'")
