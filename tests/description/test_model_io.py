"""Round trips of models, scenarios and results through plain JSON; the presets' documented facts."""
import json

import numpy as np
import pytest

from pneucore import (MODEL_PRESETS, SCENARIO_PRESETS, Model, Scenario, SimulationResult,
                      model_preset, scenario_preset, simulate)
from pneucore.result import SERIES_UNITS

MODES = {"slide", "stick", "stop", "locked"}
#: Series every result has (API summary)
DOCUMENTED_SERIES = ("t", "u", "p_a", "p_b", "T_a", "T_b", "m_a", "m_b", "x", "v", "a", "q_a", "q_b",
                     "friction", "mode", "net_force", "V_a", "V_b", "u_eff", "p_supply", "q_supply",
                     "heat_a", "heat_b")
#: The scenario presets and the model each is meant for (a 4/2 command of -1 needs the 4/2 valve)
MATCHING_MODEL = {"paper-fig10-pulses": "paper-4way", "paper-fig9-switching": "paper-3way",
                  "paper-fig6-locked-max": "paper-4way", "paper-fig7-locked-min": "paper-4way"}


def assert_plain_json(obj, where="$"):
    """Only dict/list/str/int/float/bool/None, recursively (no numpy scalars, tuples, arrays)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            assert type(k) is str, f"{where}: key {k!r}"
            assert_plain_json(v, f"{where}.{k}")
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            assert_plain_json(v, f"{where}[{i}]")
    else:
        assert obj is None or type(obj) in (str, int, float, bool), f"{where}: {type(obj).__name__}"


# ----------------------------------------------------------------- models

@pytest.mark.parametrize("name", sorted(MODEL_PRESETS))
def test_model_round_trip(name):
    d1 = Model.from_dict(model_preset(name)).to_dict()
    assert_plain_json(d1)
    d2 = Model.from_dict(d1).to_dict()
    assert d2 == d1
    # through JSON text (strict: no NaN/Infinity tokens)
    text = json.dumps(d1, allow_nan=False)
    assert json.loads(text) == d1
    assert Model.from_dict(json.loads(text)).to_dict() == d1


@pytest.mark.parametrize("name", sorted(MODEL_PRESETS))
def test_model_round_trip_keeps_preset_values(name):
    preset = model_preset(name)
    d = Model.from_dict(preset).to_dict()
    assert d["jack"] == preset["jack"]
    assert d["valve"]["kind"] == preset["valve"]["kind"]
    assert d["valve"]["ports"] == preset["valve"]["ports"]
    assert d["friction"]["extend"] == preset["friction"]["extend"]
    assert d["friction"]["retract"] == preset["friction"]["retract"]
    assert d["supply"] == preset["supply"] and d["ambient"] == preset["ambient"]
    assert d["heat"] == preset["heat"]
    assert d.get("name") == preset["name"]


def test_model_round_trip_with_effects():
    d = model_preset("paper-4way")
    d["effects"] = {"piston_leakage": {}, "valve_spool_dynamics": {"time_constant": 0.01}}
    d1 = Model.from_dict(d).to_dict()
    # defaults are filled in on parse
    assert d1["effects"]["piston_leakage"] == {"conductance": 5e-11}
    assert d1["effects"]["valve_spool_dynamics"]["time_constant"] == 0.01
    assert_plain_json(d1)
    assert Model.from_dict(json.loads(json.dumps(d1, allow_nan=False))).to_dict() == d1


def test_model_from_dict_accepts_a_model_and_copies_it():
    m = Model.from_dict(model_preset("paper-4way"))
    m2 = Model.from_dict(m)
    assert m2 is not m and m2.to_dict() == m.to_dict()
    m2.jack.bore = 0.05
    assert m.jack.bore == 0.032


def _contract_json(flow_law, heat_model):
    """The model JSON of the API summary with the '...' edges filled by mirrored tables."""
    p_a = {"opening": [0.15, 1.0], "C": [0.0, 1e-8], "b": [0.3, 0.3]}
    a_r = {"opening": [-1.0, -0.15], "C": [1e-8, 0.0], "b": [0.3, 0.3]}
    p_b = {"opening": [-1.0, -0.15], "C": [1e-8, 0.0], "b": [0.3, 0.3]}   # P-A mirrored
    b_r = {"opening": [0.15, 1.0], "C": [0.0, 1e-8], "b": [0.3, 0.3]}     # A-R mirrored
    text = """
{"jack": {"bore": 0.032, "rod_a": 0.012, "rod_b": 0.012, "stroke": 0.25, "dead_volume_a": 5e-6, "dead_volume_b": 5e-6,
          "moving_mass": 2.0, "load_force": 0.0, "wall_area_a": null, "wall_area_b": null},
 "valve": {"kind": "4/2", "ports": {"P-A": %s, "A-R": %s, "P-B": %s, "B-R": %s},
           "b_chamber_pressure": null, "flow_law": "%s", "laminar_ratio": 0.999},
 "supply": {"pressure": 7e5, "temperature": 293.15}, "ambient": {"pressure": 1.013e5, "temperature": 293.15},
 "heat": {"model": "%s", "coefficient": 25.0},
 "friction": {"extend": {"fc0": 10, "fc_a": 0, "fc_b": 0, "kv0": 30, "kv_a": 0, "kv_b": 0},
              "retract": {"fc0": 10, "fc_a": 0, "fc_b": 0, "kv0": 30, "kv_a": 0, "kv_b": 0}},
 "effects": {}, "gas": {"r": 287.05, "gamma": 1.4}}
""" % (json.dumps(p_a), json.dumps(a_r), json.dumps(p_b), json.dumps(b_r), flow_law, heat_model)
    return json.loads(text)


@pytest.mark.parametrize("flow_law", ["iso6358", "saint_venant"])
@pytest.mark.parametrize("heat_model", ["isothermal", "adiabatic", "convective"])
def test_contract_json_parses(flow_law, heat_model):
    d = _contract_json(flow_law, heat_model)
    m = Model.from_dict(d)
    assert m.valve.flow_law == flow_law and m.heat.model == heat_model
    # same formula, possibly evaluated in another order: allow a few ulps
    assert m.jack.area_a == pytest.approx(np.pi / 4 * (0.032 ** 2 - 0.012 ** 2), rel=1e-14)
    out = m.to_dict()
    assert Model.from_dict(out).to_dict() == out
    assert_plain_json(out)
    # ints in the input (fc0: 10) come back as floats but compare equal
    assert out["friction"]["extend"]["fc0"] == 10.0
    # and it simulates
    s = scenario_preset("paper-fig10-pulses")
    s["duration"] = 0.4
    res = simulate(d, s)
    assert res.status == 0
    assert res.x[-1] != res.x[0]   # the 0.18 s extension pulse moves the piston


# ----------------------------------------------------------------- scenarios

@pytest.mark.parametrize("name", sorted(SCENARIO_PRESETS))
def test_scenario_round_trip(name):
    model = Model.from_dict(model_preset(MATCHING_MODEL[name]))
    d1 = Scenario.from_dict(scenario_preset(name), model).to_dict()
    assert_plain_json(d1)
    assert Scenario.from_dict(d1, model).to_dict() == d1
    text = json.dumps(d1, allow_nan=False)
    assert Scenario.from_dict(json.loads(text), model).to_dict() == d1
    preset = scenario_preset(name)
    for key in ("duration", "sample_period", "command", "command_interpolation", "locked", "x0",
                "initial"):
        assert d1[key] == preset[key], key
    assert set(d1["solver"]) == {"rtol", "max_step", "max_steps", "max_events"}


def test_scenario_round_trip_custom_solver():
    d = {"duration": 0.5, "sample_period": 0.002, "command": [[0, 0], [0.1, 0.5], [0.2, -0.25]],
         "command_interpolation": "linear", "x0": 0.1,
         "initial": {"p_a": 2e5, "p_b": 3e5, "T_a": 300.0, "T_b": None},
         "solver": {"rtol": 1e-6, "max_step": 0.005, "max_steps": 1000, "max_events": 500}}
    d1 = Scenario.from_dict(d).to_dict()
    assert Scenario.from_dict(d1).to_dict() == d1
    assert d1["solver"] == d["solver"]
    assert d1["initial"] == d["initial"]
    assert d1["command"] == [[0.0, 0.0], [0.1, 0.5], [0.2, -0.25]]
    assert_plain_json(d1)
    assert Scenario.from_dict(Scenario.from_dict(d)).to_dict() == d1


# ----------------------------------------------------------------- results

@pytest.fixture(scope="module")
def fig10_result():
    return simulate(model_preset("paper-4way"), scenario_preset("paper-fig10-pulses"))


def test_result_to_dict_is_json(fig10_result):
    res = fig10_result
    d = res.to_dict()
    text = json.dumps(d, allow_nan=False)
    back = json.loads(text)
    assert_plain_json(back)
    n = len(res.t)
    assert n == 1001
    assert set(back["series"]) == set(res.series)
    for k, v in back["series"].items():
        assert len(v) == n, k
        assert k in back["units"], k
    for k in DOCUMENTED_SERIES:
        assert k in back["series"], k
        assert back["units"][k] == SERIES_UNITS[k]
    assert back["units"]["p_a"] == "Pa" and back["units"]["x"] == "m" and back["units"]["t"] == "s"
    assert isinstance(back["events"], list) and back["events"]
    for ev in back["events"]:
        assert set(ev) >= {"t", "kind", "mode"}
        assert ev["kind"] in {"command", "slip", "stick", "stop", "reverse"}
    # the 8 command breakpoints after t = 0 each log a command event
    assert sum(ev["kind"] == "command" for ev in back["events"]) == 8
    for key in ("steps", "rejected", "rhs_evaluations", "jacobians", "events", "t_reached"):
        assert key in back["stats"], key
    assert back["status"] == 0 and back["message"] == "ok"
    assert back["model"] == res.model.to_dict()
    assert back["scenario"] == res.scenario.to_dict()
    # values survive the export exactly (float -> JSON text -> float is exact in Python)
    assert np.array_equal(np.array(back["series"]["p_a"]), res.p_a)
    assert back["series"]["mode"] == list(res.mode)


def test_result_to_dict_subset(fig10_result):
    d = fig10_result.to_dict(series=["t", "x"])
    assert set(d["series"]) == {"t", "x"} == set(d["units"])
    json.dumps(d, allow_nan=False)


def test_result_to_pandas(fig10_result):
    import pandas as pd  # in the test dependencies: a missing one must fail, not skip
    df = fig10_result.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert len(df) == len(fig10_result.t)
    assert df.index.name == "t"
    assert np.array_equal(df.index.to_numpy(), fig10_result.t)
    for k in DOCUMENTED_SERIES:
        if k != "t":
            assert k in df.columns, k
    assert np.array_equal(df["p_a"].to_numpy(), fig10_result.p_a)
    assert set(df["mode"]) <= MODES


# ----------------------------------------------------------------- presets

def test_paper_4way_geometry():
    d = model_preset("paper-4way")
    j = d["jack"]
    assert j["bore"] == 0.032 and j["rod_a"] == 0.012 and j["rod_b"] == 0.012 and j["stroke"] == 0.25
    assert d["valve"]["kind"] == "4/2"
    assert set(d["valve"]["ports"]) == {"P-A", "A-R", "P-B", "B-R"}


def test_paper_4way_overlap_closes_every_edge():
    """15 % overlap: C is exactly 0 on every edge for |u| <= 0.15 (np.interp holds end values
    outside the table, as the valve does)."""
    ports = model_preset("paper-4way")["valve"]["ports"]
    u = np.linspace(-0.15, 0.15, 301)
    for name, table in ports.items():
        C = np.interp(u, table["opening"], table["C"])
        assert np.all(C == 0.0), name
    # and beyond the overlap positive u opens P-A and B-R, negative u opens P-B and A-R
    for name, sign in (("P-A", 1), ("B-R", 1), ("P-B", -1), ("A-R", -1)):
        t = ports[name]
        assert np.interp(sign * 0.16, t["opening"], t["C"]) > 0.0, name
        assert np.interp(sign * 1.0, t["opening"], t["C"]) == 1e-8, name   # table end value
        assert np.interp(-sign * 1.0, t["opening"], t["C"]) == 0.0, name


@pytest.mark.parametrize("u", [-0.15, -0.1, 0.0, 0.05, 0.15])
def test_paper_4way_overlap_no_flow_in_simulation(u):
    """Inside the overlap no gas moves: locked chambers keep their initial state exactly."""
    s = {"duration": 0.2, "sample_period": 0.01, "command": [[0.0, 0.0], [0.01, u]], "locked": True,
         "x0": 0.1, "initial": {"p_a": 3e5, "p_b": 2e5}}
    res = simulate(model_preset("paper-4way"), s)
    assert np.all(res.q_a == 0.0) and np.all(res.q_b == 0.0)
    assert np.all(res.p_a == res.p_a[0]) and np.all(res.p_b == res.p_b[0])
    # p -> m = p V / (r T) -> p = m r T / V round trip: a few ulps of rounding
    assert res.p_a[0] == pytest.approx(3e5, rel=1e-12)
    assert np.all(res.q_supply == 0.0)


def test_paper_3way_chamber_b_held_at_half_supply():
    d = model_preset("paper-3way")
    assert d["valve"]["kind"] == "3/2"
    assert set(d["valve"]["ports"]) == {"P-A", "A-R"}
    assert d["jack"]["bore"] == 0.032 and d["jack"]["stroke"] == 0.25
    s = scenario_preset("paper-fig9-switching")
    s["duration"] = 0.5        # one extension (0.18 s) and one retraction (0.38 s)
    res = simulate(d, s)
    half = 0.5 * d["supply"]["pressure"]
    assert np.all(res.p_b == half)          # held, not integrated: exactly constant
    assert res.model.b_chamber_pressure == half
    assert res.x.max() > 0.01               # chamber A pressure did move the piston
    assert res.p_a.max() > half


@pytest.mark.parametrize("scenario_name", sorted(SCENARIO_PRESETS))
def test_scenario_presets_simulate(scenario_name):
    model = model_preset(MATCHING_MODEL[scenario_name])
    scen = scenario_preset(scenario_name)
    res = simulate(model, scen)
    assert isinstance(res, SimulationResult)
    assert res.status == 0
    n = int(round(scen["duration"] / scen["sample_period"])) + 1
    for k in DOCUMENTED_SERIES:
        assert k in res.series, k
        assert getattr(res, k) is res.series[k]
        assert len(res.series[k]) == n, k
    # t = k * sample_period: the last grid point may differ from duration by round-off
    assert res.t[0] == 0.0 and res.t[-1] == pytest.approx(scen["duration"], abs=1e-12)
    assert set(np.unique(res.mode)) <= MODES
    assert res.events and res.stats["steps"] > 0
    for k, v in res.series.items():
        if v.dtype.kind == "f":
            assert np.all(np.isfinite(v)), k
    stroke = model["jack"]["stroke"]
    assert np.all(res.x >= 0.0) and np.all(res.x <= stroke)
    if scen["locked"]:
        assert np.all(res.x == scen["x0"])          # exactly: the piston is frozen
        assert np.all(res.v == 0.0)
        assert np.all(res.mode == "locked")
        assert np.all(res.V_a == res.V_a[0]) and np.all(res.V_b == res.V_b[0])
        assert res.p_a.max() > 0.9 * model["supply"]["pressure"]   # valve opened at 0.05 s for 0.5 s
    else:
        assert res.x.max() - res.x.min() > 1e-3
        assert {"slide"} <= set(res.mode)
