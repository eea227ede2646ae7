"""Every invalid model or scenario raises one clear ValueError naming the field path.

Each case starts from a valid model + scenario (paper-4way + a short Fig. 10
run, or paper-3way + a short Fig. 9 run), breaks exactly one thing, and
checks that

* ``simulate(model, scenario)`` raises a ``ValueError`` (``FieldError``)
  before anything is integrated,
* the direct parser (``Model.from_dict`` or ``Scenario.from_dict(s, model)``)
  raises the same,
* the message starts with the exact dotted field path followed by ``": "``
  and an explanation, and ``FieldError.path`` is that path.

The last part checks that a simulation that cannot proceed stops with a
``SimulationError`` carrying a partial result with NaN only after the time
reached, and that a normal result contains no NaN at all.
"""
import copy
import json
import math
import re

import numpy as np
import pytest

from pneucore import (FieldError, Model, Scenario, SimulationError, model_preset, scenario_preset,
                      simulate)
from pneucore.description.scenario import MAX_DURATION, MAX_SAMPLES

MODES = {"slide", "stick", "stop", "locked"}
SOLVER = {"rtol": 1e-5, "max_step": 0.02, "max_steps": 5_000_000, "max_events": 200_000}


# ----------------------------------------------------------------- baselines

def base4():
    """paper-4way + a short Fig. 10 run (short so that a case that wrongly passes stays cheap)."""
    s = scenario_preset("paper-fig10-pulses")
    s["duration"] = 0.05
    s["solver"] = dict(SOLVER)
    return {"model": model_preset("paper-4way"), "scenario": s}


def base3():
    """paper-3way + a short Fig. 9 run."""
    s = scenario_preset("paper-fig9-switching")
    s["duration"] = 0.05
    s["solver"] = dict(SOLVER)
    return {"model": model_preset("paper-3way"), "scenario": s}


# ----------------------------------------------------------------- path helpers

def _tokens(path):
    """'valve.ports.P-A.b[0]' -> ['valve', 'ports', 'P-A', 'b', 0]."""
    out = []
    for part in path.split("."):
        m = re.fullmatch(r"([^\[\]]+)((?:\[\d+\])*)", part)
        assert m, part
        out.append(m.group(1))
        out += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return out


DELETE = object()


def _set(ctx, path, value):
    """Set (or delete with DELETE) ``path`` in ctx; 'scenario.*' paths go to the scenario."""
    toks = _tokens(path)
    if toks[0] == "scenario":
        node, toks = ctx["scenario"], toks[1:]
    else:
        node = ctx["model"]
    for t in toks[:-1]:
        node = node.setdefault(t, {}) if isinstance(node, dict) else node[t]
    if value is DELETE:
        del node[toks[-1]]
    else:
        node[toks[-1]] = value


def M(path, value):
    """Mutator: set a model (or 'scenario.'-prefixed) path to value."""
    def mutate(ctx):
        _set(ctx, path, value)
    return mutate


S = M  # scenario paths are spelled with their 'scenario.' prefix


def J(path, token):
    """Mutator: the value arrives as raw JSON text ``token`` (e.g. NaN, Infinity, 1e999)."""
    def mutate(ctx):
        _set(ctx, path, "__SENTINEL__")
        for key in ("model", "scenario"):
            text = json.dumps(ctx[key])
            if '"__SENTINEL__"' in text:
                ctx[key] = json.loads(text.replace('"__SENTINEL__"', token))
    return mutate


def seq(*mutators):
    def mutate(ctx):
        for m in mutators:
            m(ctx)
    return mutate


def three_way(*mutators):
    """Mutators applied on the 3/2 baseline instead of the 4/2 one."""
    def mutate(ctx):
        ctx.update(base3())
        for m in mutators:
            m(ctx)
    return mutate


def heat_model(name):
    return M("heat.model", name)


def pset(path_prefix, **values):
    def mutate(ctx):
        for k, v in values.items():
            _set(ctx, f"{path_prefix}.{k}", v)
    return mutate


# ----------------------------------------------------------------- cases

CASES = []


def case(id_, mutate, expected):
    CASES.append(pytest.param(mutate, expected, id=id_))


# --- negative or zero sizes
for fld in ("bore", "stroke", "dead_volume_a", "dead_volume_b", "moving_mass", "wall_area_a",
            "wall_area_b"):
    case(f"jack.{fld}=0", M(f"jack.{fld}", 0.0), f"jack.{fld}")
    case(f"jack.{fld}<0", M(f"jack.{fld}", -1e-3), f"jack.{fld}")
    case(f"jack.{fld}=0(int)", M(f"jack.{fld}", 0), f"jack.{fld}")
case("jack.rod_a<0", M("jack.rod_a", -0.001), "jack.rod_a")
case("jack.rod_b<0", M("jack.rod_b", -0.001), "jack.rod_b")
case("supply.temperature=0", M("supply.temperature", 0.0), "supply.temperature")
case("ambient.pressure=0", M("ambient.pressure", 0.0), "ambient.pressure")
case("ambient.temperature<0", M("ambient.temperature", -1.0), "ambient.temperature")
case("gas.r=0", M("gas.r", 0.0), "gas.r")
case("gas.gamma=1", M("gas.gamma", 1.0), "gas.gamma")
case("heat.coefficient<0", M("heat.coefficient", -1.0), "heat.coefficient")
case("friction.extend.fc0<0", M("friction.extend.fc0", -1.0), "friction.extend.fc0")
case("friction.retract.kv0<0", M("friction.retract.kv0", -1.0), "friction.retract.kv0")

# --- rod >= bore, each side
case("rod_a==bore", M("jack.rod_a", 0.032), "jack.rod_a")
case("rod_a>bore", M("jack.rod_a", 0.04), "jack.rod_a")
case("rod_b==bore", M("jack.rod_b", 0.032), "jack.rod_b")
case("rod_b>bore", M("jack.rod_b", 0.05), "jack.rod_b")
case("bore<rods", M("jack.bore", 0.01), "jack.rod_a")

# --- x0 outside the stroke (above it needs the model: checked against jack.stroke)
case("x0<0", S("scenario.x0", -0.01), "scenario.x0")
case("x0>stroke", S("scenario.x0", 0.2501), "scenario.x0")
case("x0>>stroke", S("scenario.x0", 1.0), "scenario.x0")
case("x0>stroke-locked", seq(S("scenario.x0", 0.3), S("scenario.locked", True)), "scenario.x0")
case("x0>stroke-3way", three_way(S("scenario.x0", 0.26)), "scenario.x0")

# --- b outside [0, 1)
case("b=1", M("valve.ports.P-A.b[0]", 1.0), "valve.ports.P-A.b[0]")
case("b>1", M("valve.ports.B-R.b[2]", 1.5), "valve.ports.B-R.b[2]")
case("b<0", M("valve.ports.A-R.b[4]", -0.1), "valve.ports.A-R.b[4]")
case("b=1-3way", three_way(M("valve.ports.A-R.b[1]", 1.0)), "valve.ports.A-R.b[1]")

# --- negative C
case("C<0", M("valve.ports.A-R.C[1]", -1e-9), "valve.ports.A-R.C[1]")
case("C<0-P-B", M("valve.ports.P-B.C[0]", -1e-12), "valve.ports.P-B.C[0]")
case("C<0-3way", three_way(M("valve.ports.P-A.C[1]", -3.2e-9)), "valve.ports.P-A.C[1]")
# --- C beyond any valve (VALVE_C_MAX: a catalogue's dm^3/(s bar) typed as SI, say)
case("C>max", M("valve.ports.P-A.C[4]", 1.0), "valve.ports.P-A.C[4]")
case("C>max-3way", three_way(M("valve.ports.A-R.C[0]", 1.01e-4)), "valve.ports.A-R.C[0]")

# --- non-increasing openings, openings outside the valve's range
case("opening-equal", M("valve.ports.P-A.opening", [0.15, 0.3, 0.3, 0.75, 1.0]),
     "valve.ports.P-A.opening[2]")
case("opening-decreasing", M("valve.ports.B-R.opening", [0.15, 0.5, 0.3, 0.75, 1.0]),
     "valve.ports.B-R.opening[2]")
case("opening-reversed", M("valve.ports.A-R.opening", [-0.15, -0.3, -0.5, -0.75, -1.0]),
     "valve.ports.A-R.opening[1]")
case("opening>1", M("valve.ports.P-A.opening[4]", 1.5), "valve.ports.P-A.opening[4]")
case("opening<-1", M("valve.ports.P-B.opening[0]", -1.2), "valve.ports.P-B.opening[0]")
case("opening<0-3way", three_way(M("valve.ports.P-A.opening[0]", -0.1)), "valve.ports.P-A.opening[0]")
case("opening-empty", M("valve.ports.P-A", {"opening": [], "C": [], "b": []}),
     "valve.ports.P-A.opening")

# --- table length mismatch
case("C-shorter", M("valve.ports.P-A.C", [0.0, 1e-9, 5e-9, 1e-8]), "valve.ports.P-A.C")
case("b-longer", M("valve.ports.A-R.b", [0.3] * 6), "valve.ports.A-R.b")
case("m-mismatch", M("valve.ports.P-B.m", [0.5, 0.5]), "valve.ports.P-B.m")
case("C-scalar", M("valve.ports.P-A.C", 1e-8), "valve.ports.P-A.C")
case("C-missing", M("valve.ports.P-A.C", DELETE), "valve.ports.P-A.C")
case("opening-missing", M("valve.ports.B-R.opening", DELETE), "valve.ports.B-R.opening")

# --- missing edges for the valve kind, edges of another kind
case("missing-B-R", M("valve.ports.B-R", DELETE), "valve.ports.B-R")
case("missing-P-A", M("valve.ports.P-A", DELETE), "valve.ports.P-A")
case("missing-A-R-3way", three_way(M("valve.ports.A-R", DELETE)), "valve.ports.A-R")
case("no-ports", M("valve.ports", {}), "valve.ports.P-A")
case("3/2-with-P-B", M("valve.kind", "3/2"), "valve.ports.P-B")  # a 3/2 valve has no P-B edge
case("ports-not-object", M("valve.ports", [1, 2]), "valve.ports")
case("port-not-object", M("valve.ports.P-A", [0.15, 1.0]), "valve.ports.P-A")

# --- unknown names: valve kind, heat model, flow law, friction law, effect, effect parameter
case("kind-5/3", M("valve.kind", "5/3"), "valve.kind")
case("kind-empty", M("valve.kind", ""), "valve.kind")
case("kind-null", M("valve.kind", None), "valve.kind")
case("kind-list", M("valve.kind", ["4/2"]), "valve.kind")
case("kind-object", M("valve.kind", {"name": "4/2"}), "valve.kind")
case("heat-radiative", M("heat.model", "radiative"), "heat.model")
case("heat-list", M("heat.model", ["convective"]), "heat.model")
case("flow-law-unknown", M("valve.flow_law", "bernoulli"), "valve.flow_law")
case("flow-law-case", M("valve.flow_law", "ISO6358"), "valve.flow_law")
case("flow-law-list", M("valve.flow_law", []), "valve.flow_law")
case("friction-law-unknown", M("friction.law", "lugre"), "friction.law")
case("effect-unknown", M("effects", {"piston_leak": {}}), "effects.piston_leak")
case("effect-param-unknown", M("effects", {"piston_leakage": {"conductanse": 1e-11}}),
     "effects.piston_leakage.conductanse")
case("effect-param-above-max", M("effects", {"piston_leakage": {"conductance": 1.0}}),
     "effects.piston_leakage.conductance")
case("effect-param-below-min", M("effects", {"sensor_lag": {"time_constant": -0.001}}),
     "effects.sensor_lag.time_constant")
case("effect-param-nan", M("effects", {"dead_volume": {"volume_a": float("nan")}}),
     "effects.dead_volume.volume_a")
case("effect-param-string", M("effects", {"dead_volume": {"volume_b": "1e-5"}}),
     "effects.dead_volume.volume_b")
case("effect-param-bool", M("effects", {"valve_null_leakage": {"fraction": True}}),
     "effects.valve_null_leakage.fraction")
case("effect-params-not-object", M("effects", {"piston_leakage": 5e-11}), "effects.piston_leakage")
case("effects-not-object", M("effects", ["piston_leakage"]), "effects")
case("interp-unknown", S("scenario.command_interpolation", "cubic"), "scenario.command_interpolation")

# --- NaN and infinite numbers: as Python floats, as numpy scalars, and as they arrive in JSON
NONFINITE_FIELDS = [
    "jack.bore", "jack.load_force", "jack.wall_area_a", "supply.pressure", "ambient.temperature",
    "valve.ports.P-A.C[1]", "valve.ports.B-R.opening[3]", "valve.laminar_ratio",
    "friction.extend.kv0", "friction.retract.fc_a", "heat.coefficient", "gas.gamma",
    "scenario.duration", "scenario.sample_period", "scenario.x0", "scenario.command[1][0]",
    "scenario.command[1][1]", "scenario.initial.p_a", "scenario.initial.T_b",
    "scenario.solver.rtol", "scenario.solver.max_steps",
]
for fld in NONFINITE_FIELDS:
    case(f"{fld}=nan", M(fld, float("nan")), fld)
    case(f"{fld}=inf", M(fld, float("inf")), fld)
    case(f"{fld}=-inf", M(fld, -math.inf), fld)
    case(f"{fld}=np.float32(nan)", M(fld, np.float32("nan")), fld)
    # json.loads accepts these non-standard tokens (Python's json, JavaScript clients)
    case(f"{fld}=json:NaN", J(fld, "NaN"), fld)
    case(f"{fld}=json:Infinity", J(fld, "Infinity"), fld)
    case(f"{fld}=json:-Infinity", J(fld, "-Infinity"), fld)
    case(f"{fld}=json:1e999", J(fld, "1e999"), fld)      # overflows to inf when parsed
    case(f"{fld}=json:'NaN'", J(fld, '"NaN"'), fld)      # quoted: a string, not a number
# a JSON integer literal too large for a float (json.loads gives a Python int) must not escape
# as OverflowError; one field per parser (all go through validation.number)
for fld in ("jack.bore", "valve.ports.P-A.C[1]", "scenario.duration", "scenario.command[1][1]"):
    case(f"{fld}=json:huge-int", J(fld, "1" + "0" * 400), fld)
case("effect-param=json:Infinity", seq(M("effects", {"piston_leakage": {"conductance": 0.0}}),
                                        J("effects.piston_leakage.conductance", "Infinity")),
     "effects.piston_leakage.conductance")

# --- strings where numbers are expected
for fld, text in [("jack.bore", "0.032"), ("jack.moving_mass", "2 kg"), ("supply.pressure", "7e5"),
                  ("friction.extend.fc0", "10"), ("valve.ports.P-A.opening[0]", "0.15"),
                  ("valve.ports.A-R.b[0]", "0.3"), ("valve.b_chamber_pressure", "3.5e5"),
                  ("heat.coefficient", "25"), ("scenario.duration", "1.0"), ("scenario.x0", "0"),
                  ("scenario.command[1][0]", "0.18"), ("scenario.command[1][1]", "0.7"),
                  ("scenario.initial.p_a", "1e5"), ("scenario.solver.max_steps", "100"),
                  ("scenario.sample_period", "")]:
    case(f"{fld}=str", M(fld, text), fld)
case("C-string-list", M("valve.ports.P-A.C", "[0, 1e-8]"), "valve.ports.P-A.C")
case("C-dict", M("valve.ports.P-A.C", {"0": 0.0}), "valve.ports.P-A.C")
case("bore-list", M("jack.bore", [0.032]), "jack.bore")
case("bore-dict", M("jack.bore", {"value": 0.032}), "jack.bore")
case("bore-null", M("jack.bore", None), "jack.bore")

# --- booleans where numbers are expected (bool is an int subclass in Python)
for fld, val in [("jack.bore", True), ("jack.moving_mass", True), ("jack.load_force", False),
                 ("jack.wall_area_a", True), ("valve.ports.P-A.b[0]", False),
                 ("valve.ports.P-A.C[1]", True), ("heat.coefficient", True), ("gas.r", True),
                 ("scenario.duration", True), ("scenario.sample_period", True),
                 ("scenario.x0", False), ("scenario.command[0][1]", True),
                 ("scenario.command[1][0]", True), ("scenario.initial.p_a", True),
                 ("scenario.solver.max_steps", True), ("scenario.solver.rtol", True)]:
    case(f"{fld}={val}", M(fld, val), fld)
case("locked-string", S("scenario.locked", "yes"), "scenario.locked")
case("locked-int", S("scenario.locked", 1), "scenario.locked")
case("locked-null", S("scenario.locked", None), "scenario.locked")

# --- supply at or below ambient is accepted (filling from the atmosphere, a vacuum line,
# tests/physics/test_heat_models.py); rarefied sources and a 3/2 chamber B at "half a vacuum" are not
case("supply-rarefied", M("supply.pressure", 500.0), "supply.pressure")
case("ambient-rarefied", M("ambient.pressure", 500.0), "ambient.pressure")
case("vacuum-3way-default-b", three_way(M("supply.pressure", 0.2e5)), "valve.b_chamber_pressure")
case("supply<0", M("supply.pressure", -7e5), "supply.pressure")

# --- other valve settings
case("b_chamber_pressure-on-4/2", M("valve.b_chamber_pressure", 3.5e5), "valve.b_chamber_pressure")
case("b_chamber_pressure<0-3way", three_way(M("valve.b_chamber_pressure", -1.0)),
     "valve.b_chamber_pressure")
case("laminar_ratio=1", M("valve.laminar_ratio", 1.0), "valve.laminar_ratio")
case("laminar_ratio=0.5", M("valve.laminar_ratio", 0.5), "valve.laminar_ratio")

# --- duration and sample count limits
case("duration>MAX", seq(S("scenario.duration", MAX_DURATION + 1.0), S("scenario.sample_period", 10.0)),
     "scenario.duration")
case("duration>>MAX", seq(S("scenario.duration", MAX_DURATION * 100), S("scenario.sample_period", 100.0)),
     "scenario.duration")
case("duration=0", S("scenario.duration", 0.0), "scenario.duration")
case("duration<0", S("scenario.duration", -1.0), "scenario.duration")
case("sample_period=0", S("scenario.sample_period", 0.0), "scenario.sample_period")
case("sample_period<0", S("scenario.sample_period", -1e-3), "scenario.sample_period")
case("samples>MAX", seq(S("scenario.duration", MAX_DURATION), S("scenario.sample_period", 1e-3)),
     "scenario.sample_period")
case("samples=MAX+1", seq(S("scenario.duration", 1.0), S("scenario.sample_period", 1.0 / MAX_SAMPLES)),
     "scenario.sample_period")
# the smallest positive float: duration / sample_period overflows to inf
case("sample_period=denormal", S("scenario.sample_period", 5e-324), "scenario.sample_period")
case("sample_period=1e-300", S("scenario.sample_period", 1e-300), "scenario.sample_period")

# --- command: decreasing times, malformed points, outside the valve's range
case("cmd-decreasing", S("scenario.command", [[0, 0], [0.5, 0.7], [0.4, 0]]), "scenario.command[2][0]")
case("cmd-negative-time", S("scenario.command", [[-0.1, 0], [0.5, 0.7]]), "scenario.command[0][0]")
case("cmd-short-point", S("scenario.command", [[0, 0], [0.5]]), "scenario.command[1]")
case("cmd-long-point", S("scenario.command", [[0, 0, 1]]), "scenario.command[0]")
case("cmd-flat", S("scenario.command", [0, 0]), "scenario.command[0]")
case("cmd-dict-point", S("scenario.command", [{"t": 0, "u": 0}]), "scenario.command[0]")
case("cmd-string-point", S("scenario.command", ["0,0"]), "scenario.command[0]")
case("cmd-null-time", S("scenario.command", [[None, 0]]), "scenario.command[0][0]")
case("cmd-empty", S("scenario.command", []), "scenario.command")
case("cmd-string", S("scenario.command", "0 0"), "scenario.command")
case("cmd-null", S("scenario.command", None), "scenario.command")
case("cmd-object", S("scenario.command", {"0": 0}), "scenario.command")
case("cmd>1-4/2", S("scenario.command[2][1]", 1.5), "scenario.command[2][1]")
case("cmd<-1-4/2", S("scenario.command[3][1]", -1.01), "scenario.command[3][1]")
case("cmd<0-3/2", three_way(S("scenario.command[0][1]", -0.1)), "scenario.command[0][1]")
case("cmd>1-3/2", three_way(S("scenario.command[1][1]", 1.2)), "scenario.command[1][1]")
case("cmd-4way-on-3/2", three_way(S("scenario.command", [[0, 0], [0.01, -0.7]])), "scenario.command[1][1]")

# --- initial state
case("p_a=0", S("scenario.initial.p_a", 0.0), "scenario.initial.p_a")
case("p_a<0", S("scenario.initial.p_a", -1e5), "scenario.initial.p_a")
case("p_b=0", S("scenario.initial.p_b", 0.0), "scenario.initial.p_b")
case("p_b<0", S("scenario.initial.p_b", -1.0), "scenario.initial.p_b")
case("T_a=0", S("scenario.initial.T_a", 0.0), "scenario.initial.T_a")
case("T_b<0", S("scenario.initial.T_b", -10.0), "scenario.initial.T_b")
case("p_b-on-3/2", three_way(S("scenario.initial.p_b", 2e5)), "scenario.initial.p_b")
case("T_a-isothermal", seq(heat_model("isothermal"), S("scenario.initial.T_a", 350.0)),
     "scenario.initial.T_a")
case("initial-not-object", S("scenario.initial", [1e5, 1e5]), "scenario.initial")

# --- unknown keys (typos)
for path in ["jack.bor", "valve.kinds", "valve.ports.P-A.opennig", "valve.ports.P-X", "supply.presure",
             "ambient.temp", "heat.modle", "friction.extend.fc_0", "friction.retrac", "gas.R", "jak",
             "scenario.duraton", "scenario.initial.pa", "scenario.solver.atol", "scenario.x_0"]:
    case(f"unknown-{path}", M(path, 1.0), path)

# --- structure
case("jack-missing", M("jack", DELETE), "jack")
case("valve-missing", M("valve", DELETE), "valve")
case("jack-not-object", M("jack", [0.032, 0.012]), "jack")
case("friction.extend-not-object", M("friction.extend", 10.0), "friction.extend")
case("supply-not-object", M("supply", 7e5), "supply")

# --- solver settings out of range
for key, bad in [("rtol", 0.0), ("rtol", -1e-5), ("rtol", 1e-14), ("rtol", 0.1), ("rtol", 1.0),
                 ("max_step", 0.0), ("max_step", -0.01), ("max_step", 2.0),
                 ("max_steps", 0), ("max_steps", -5), ("max_steps", 9), ("max_steps", 1e9),
                 ("max_events", 0), ("max_events", 9), ("max_events", 1e8)]:
    case(f"solver.{key}={bad}", S(f"scenario.solver.{key}", bad), f"scenario.solver.{key}")
case("solver-not-object", S("scenario.solver", "fast"), "scenario.solver")


def _parse_direct(ctx, expected):
    """The parser that owns the field: Scenario.from_dict (with the model) or Model.from_dict."""
    if expected.startswith("scenario"):
        model = Model.from_dict(ctx["model"])
        Scenario.from_dict(ctx["scenario"], model)
    else:
        Model.from_dict(ctx["model"])


def _assert_field_error(excinfo, expected):
    msg = str(excinfo.value)
    assert msg.startswith(expected + ": "), f"expected the message to start with {expected!r}: {msg!r}"
    assert len(msg) > len(expected) + 5, f"message explains nothing: {msg!r}"
    assert isinstance(excinfo.value, FieldError)
    assert excinfo.value.path == expected


def test_baselines_are_valid():
    """Each case breaks exactly one thing of a valid baseline."""
    for ctx in (base4(), base3()):
        model = Model.from_dict(ctx["model"])
        Scenario.from_dict(ctx["scenario"], model)
        res = simulate(ctx["model"], ctx["scenario"])
        assert res.status == 0


@pytest.mark.parametrize("mutate, expected", CASES)
def test_invalid_input_names_the_field(mutate, expected):
    ctx = base4()
    mutate(ctx)
    with pytest.raises(ValueError) as excinfo:
        simulate(copy.deepcopy(ctx["model"]), copy.deepcopy(ctx["scenario"]))
    _assert_field_error(excinfo, expected)
    with pytest.raises(ValueError) as excinfo:
        _parse_direct(ctx, expected)
    _assert_field_error(excinfo, expected)


def test_sample_limit_boundary_is_accepted():
    """Exactly MAX_SAMPLES samples is allowed (parsed only: not simulated)."""
    s = Scenario.from_dict({"duration": 2.0, "sample_period": 2.0 / (MAX_SAMPLES - 1)})
    assert s.duration == 2.0
    s = Scenario.from_dict({"duration": MAX_DURATION, "sample_period": 10.0})
    assert s.duration == MAX_DURATION


def test_model_and_scenario_not_objects():
    with pytest.raises(ValueError) as excinfo:
        Model.from_dict([1, 2, 3])
    _assert_field_error(excinfo, "model")
    with pytest.raises(ValueError) as excinfo:
        Scenario.from_dict("fast")
    _assert_field_error(excinfo, "scenario")


def test_validation_does_not_mutate_input():
    ctx = base4()
    ctx["model"]["effects"] = {"piston_leakage": {}}
    before = copy.deepcopy(ctx)
    Model.from_dict(ctx["model"])
    Scenario.from_dict(ctx["scenario"], Model.from_dict(ctx["model"]))
    assert ctx == before


# ----------------------------------------------------------------- solver failures

FLOAT_SERIES_SKIP = {"t"}


def _float_series(res):
    return {k: v for k, v in res.series.items() if v.dtype.kind == "f" and k not in FLOAT_SERIES_SKIP}


def _assert_partial(res, duration):
    """NaN exactly after the time reached, finite (and a valid mode) up to it."""
    assert res.status != 0
    t_reached = res.stats["t_reached"]
    assert 0.0 <= t_reached < duration
    after = res.t > t_reached
    assert after.any() and not after.all()
    assert np.all(np.isfinite(res.t))
    for name, v in _float_series(res).items():
        assert np.all(np.isnan(v[after])), f"{name}: values after t_reached = {t_reached}"
        assert np.all(np.isfinite(v[~after])), f"{name}: NaN before t_reached = {t_reached}"
    assert set(res.mode[~after]) <= MODES
    assert not (set(res.mode[after]) & MODES)
    # JSON export turns the missing samples into null
    d = res.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["series"]["p_a"][-1] is None
    assert d["status"] == res.status and d["message"] == res.message


def test_max_steps_exhausted_raises_with_partial_result(paper4, pulses):
    pulses["solver"] = {"max_steps": 10}
    with pytest.raises(SimulationError) as excinfo:
        simulate(paper4, pulses)
    err = excinfo.value
    assert isinstance(err, RuntimeError)
    assert "max_steps" in str(err)
    assert "stopped at t =" in str(err)
    assert err.result is not None
    _assert_partial(err.result, pulses["duration"])
    assert err.result.message in str(err)


def test_max_steps_exhausted_without_raising(paper4, pulses):
    pulses["solver"] = {"max_steps": 10}
    res = simulate(paper4, pulses, raise_on_error=False)
    assert "max_steps" in res.message
    _assert_partial(res, pulses["duration"])


def test_event_budget_exhausted_raises(paper4, pulses):
    # the Fig. 10 run has more than 10 command/stick/slip events
    pulses["solver"] = {"max_events": 10}
    with pytest.raises(SimulationError) as excinfo:
        simulate(paper4, pulses)
    assert "max_events" in str(excinfo.value)
    _assert_partial(excinfo.value.result, pulses["duration"])


@pytest.mark.parametrize("model_name, scenario_name", [
    ("paper-4way", "paper-fig10-pulses"), ("paper-3way", "paper-fig9-switching"),
    ("paper-4way", "paper-fig6-locked-max"), ("paper-4way", "paper-fig7-locked-min")])
def test_normal_result_has_no_nan(model_name, scenario_name):
    scenario = scenario_preset(scenario_name)
    res = simulate(model_preset(model_name), scenario)
    assert res.status == 0 and res.message == "ok"
    # the last step is clipped to the end time; allow round-off of summing step sizes
    assert res.stats["t_reached"] == pytest.approx(scenario["duration"], abs=1e-12)
    for name, v in res.series.items():
        if v.dtype.kind == "f":
            assert np.all(np.isfinite(v)), name
    assert set(res.mode) <= MODES


# ----------------------------------------------------------------------------- command fast path
from hypothesis import given, settings, strategies as st  # noqa: E402

_NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5),
                     st.booleans(), st.none(), st.text(max_size=2))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.tuples(_NUMBERS, _NUMBERS).map(list), st.tuples(_NUMBERS, _NUMBERS),
                          st.lists(_NUMBERS, max_size=3)), min_size=1, max_size=6))
def test_the_command_fast_path_accepts_and_refuses_as_the_full_check(cmd):
    # the fast acceptance of plain commands must change nothing: the same breakpoints, or
    # the same error naming the same breakpoint, with and without it
    import pneucore.description.scenario as sc
    from pneucore import Scenario, scenario_preset
    base = scenario_preset("paper-fig10-pulses")

    def outcome():
        try:
            return Scenario.from_dict(dict(base, command=cmd)).command
        except FieldError as exc:
            return (exc.path, exc.detail)
    fast = outcome()
    real = sc._plain_command
    sc._plain_command = lambda c: None
    try:
        full = outcome()
    finally:
        sc._plain_command = real
    assert fast == full
