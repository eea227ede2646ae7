"""Tests on data with a hidden effect: does ``diagnose`` name what the data hide?

Every catalog effect is hidden in turn in synthetic measurements
(:func:`pneucore.data.synthetic.synthetic_experiments`: a locked hold test and the
Fig. 10 free pulse test, 1 s at 1 kHz, 12-bit quantised, Gaussian noise of
about 1.2 LSB), and the model *without* the effect is diagnosed. The
diagnosis must name the effect first, bring the Eq. 25 error down to what the
true model achieves on the same noisy data, and refit the hidden parameters.

Controls: data without a hidden effect give no verdict; two hidden effects are
found in two rounds (diagnose, apply, diagnose again); the JSON report, the
``candidates`` restriction and ``uncertain`` base parameters.

"Noise floor" below is the Eq. 25 overall error of the TRUE model on the same
data (``compare(truth, exps).overall``): the best any model can do.
"""
import functools
import json
import math

import pytest

from pneucore import EFFECTS, Model, model_preset
from pneucore.analysis.compare import compare
from pneucore.analysis.diagnose import apply_diagnosis, diagnose
from pneucore.data.synthetic import synthetic_experiments

#: The error after adding the right effect may exceed the noise floor by at most 20 %: the refit
#: has 1-2 free parameters against ~5000 samples, so a correct model lands within a fraction of
#: a percent of the floor; 20 % leaves room for a refit stopped by the optimiser's budget but
#: not for a wrong or partial explanation (those leave errors of several times the floor).
FLOOR_FACTOR = 1.2
#: Refitted effect parameters must come back within 20 % of the truth: the effects are set
#: clearly observable (error before = 1.3x-100x the floor), so the refit's standard errors are
#: below 1 % of the value (the Stribeck velocity, seen only at the few starts from rest: ~6 %);
#: 20 % tolerates that plus the bias of the initial-condition estimate, not a wrong effect.
PARAM_RTOL = 0.20

#: Constant, symmetric friction (no pressure dependence, extend = retract): the base for the
#: two friction effects, which cannot be added to a model that already has their feature.
CONSTANT_SYMMETRIC_FRICTION = {"fc0": 8.0, "fc_a": 0.0, "fc_b": 0.0, "kv0": 40.0, "kv_a": 0.0,
                               "kv_b": 0.0}

#: The hidden effect of each case, with every parameter spelled out. Strengths are physically
#: reasonable for the paper's 32 mm jack, inside the catalog bounds and away from the probe
#: values the score pass uses (the refit starts from the probe values, so a truth equal to them
#: would be found without fitting anything). Parameters the diagnosis does not refit
#: (``fit_params``) are at the values the refit holds them at (catalog defaults).
HIDDEN = {
    # convective exchange, h = 40 W/(m^2 K) (probe 25); see truth_model: the truth has the base
    # model's own convective heat model, not the effect
    "heat_exchange": {"h": 40.0},
    # 1.5e-10 kg/(s Pa): ~0.1 g/s at 6 bar across a worn piston seal (probe 5e-11)
    "piston_leakage": {"conductance": 1.5e-10},
    # rod-seal / fitting leaks of different size on A and B (probe 5e-11 each)
    "external_leakage": {"conductance_a": 1.0e-10, "conductance_b": 7.0e-11},
    # 8 ms first-order spool lag (probe 5 ms); first order: natural_frequency 0
    "valve_spool_dynamics": {"time_constant": 0.008, "natural_frequency": 0.0, "damping": 0.7},
    # the valve switches 6 ms after each command away from its centre and 4 ms after each
    # command back to it (probe 5 ms each; base_model gives the paper's valve its centre as its
    # rest position, a spring-centred spool, so both times act)
    "valve_switching_delay": {"on_time": 0.006, "off_time": 0.004},
    # 1 % of the full edge conductance leaks through the centred spool (probe 0.5 %)
    "valve_null_leakage": {"fraction": 0.01},
    # breakaway force twice the Coulomb force, Stribeck velocity 15 mm/s (probe 1.5, default 10 mm/s)
    "stribeck_friction": {"static_ratio": 2.0, "stribeck_velocity": 0.015},
    # Coulomb friction growing 2 N / 1.5 N per bar in A / B (probe 1 N/bar each)
    "pressure_dependent_friction": {"fc_a": 2e-5, "fc_b": 1.5e-5, "kv_a": 0.0, "kv_b": 0.0},
    # retraction friction 6 N and 25 N s/m above extension (probe 5 N, 10 N s/m)
    "quadrant_friction": {"fc0": 6.0, "fc_a": 0.0, "fc_b": 0.0, "kv0": 25.0, "kv_a": 0.0,
                          "kv_b": 0.0},
    # 12 cm^3 / 8 cm^3 of tubing on A / B (probe 5 cm^3 each)
    "dead_volume": {"volume_a": 1.2e-5, "volume_b": 8e-6},
    # regulator C = 3e-8 m^3/(s Pa) (probe 5e-8) feeding the default 0.1 l supply line
    "supply_pressure_drop": {"C": 3e-8, "b": 0.3, "volume": 1e-4},
    # 4 ms transducer lag (probe 2 ms)
    # the controller's signals (noise, the position sensor) off: no open-loop record shows them
    "sensor_lag": {"time_constant": 0.004, "pressure_noise": 0.0, "pressure_resolution": 0.0,
                   "position_resolution": 0.0, "position_time_constant": 0.0,
                   "position_noise": 0.0},
    # Churchill-Chu natural convection at 3x the correlation on top of h = 25 (probe 1x)
    "natural_convection": {"multiplier": 3.0},
    # the inflow jet at 0.4x Woodfield's correlation through a 4 mm port (probe 1x)
    "inflow_jet_convection": {"multiplier": 0.4, "inlet_diameter": 4e-3},
    # 5 g of wall per chamber (a thin liner, the part of the wall the gas warms within a second;
    # probe 50 g), steel, 10 W/(m^2 K) outside: heavier walls act over minutes, not in this 1 s test
    "wall_heat_capacity": {"mass": 0.005, "specific_heat": 500.0, "outer_coefficient": 10.0},
    # a return spring of 500 N/m preloaded to 40 N (probe 300 N/m, 20 N)
    "return_spring": {"rate": 500.0, "preload": 40.0},
    # meter-out flow controls half / 40 % of the valve's full C on A / B (probe 3e-9 each);
    # b at the catalog default (not refitted); in series with the valve's edges (no volume
    # before them: the form the diagnosis seeks; tests/analysis/test_diagnosis_flow_control_node.py
    # has one with its volume), the check valve's values unused there
    "meter_out_throttle": {"C_a": 5e-9, "b_a": 0.3, "C_b": 4e-9, "b_b": 0.3,
                           "volume_a": 0.0, "volume_b": 0.0, "C_check": 1e-8, "b_check": 0.3},
    # meter-in flow controls, same sizes
    "meter_in_throttle": {"C_a": 5e-9, "b_a": 0.3, "C_b": 4e-9, "b_b": 0.3,
                          "volume_a": 0.0, "volume_b": 0.0, "C_check": 1e-8, "b_check": 0.3},
    # 2 m and 1.5 m of 4 mm line on A / B (probe 1 m each; the diameter is held), lumped
    "tubing": {"length_a": 2.0, "diameter_a": 4e-3, "length_b": 1.5, "diameter_b": 4e-3,
               "segments": 1.0},
    # a silencer of 0.6 dm^3/(s bar) on both exhausts (probe 0.5 dm^3/(s bar))
    "exhaust_silencer": {"C": 6e-9, "b": 0.4},
    # cushions of 20 mm / 12 mm (probe 15 mm each), needles of 3e-9 / 5e-9 m^3/(s Pa), about a
    # third of the exhaust edge's C; seen on full strokes only (FULL_STROKES)
    "end_cushion": {"length_a": 0.02, "volume_a": 0.0, "C_a": 3e-9, "length_b": 0.012,
                    "volume_b": 0.0, "C_b": 5e-9, "b": 0.3, "capacity": 0.0},
}

BUILTIN = sorted(n for n, e in EFFECTS.items() if not e.user)
#: Effects that act near the end stops only: their cases also record a full stroke each way
#: (the pulse test never reaches the ends)
FULL_STROKES = {"end_cushion"}
SEED = 1


def base_model(name=None):
    """paper-4way, adapted so that effect ``name`` can be added to it."""
    m = model_preset("paper-4way")
    if name == "heat_exchange":
        m["heat"]["model"] = "adiabatic"
    if name == "valve_switching_delay":
        # spring-centred: a command back to 0 returns the spool to rest (off_time acts)
        m["valve"]["rest_opening"] = 0.0
    if name in ("pressure_dependent_friction", "quadrant_friction"):
        m["friction"] = {"extend": dict(CONSTANT_SYMMETRIC_FRICTION),
                         "retract": dict(CONSTANT_SYMMETRIC_FRICTION)}
    return m


def truth_model(name):
    """The base plus the hidden effect (heat exchange as the convective heat model itself)."""
    m = base_model(name)
    if name == "heat_exchange":
        m["heat"] = {"model": "convective", "coefficient": HIDDEN[name]["h"]}
    else:
        m["effects"] = {name: dict(HIDDEN[name])}
    return m


def truth_value(name, param):
    return HIDDEN[name][param]


@functools.lru_cache(maxsize=None)
def hidden_case(name):
    """(base, truth, experiments, noise floor) of the case hiding ``name``."""
    truth = truth_model(name)
    exps = synthetic_experiments(truth, seed=SEED, full_strokes=name in FULL_STROKES)
    floor = compare(truth, exps).overall
    return base_model(name), truth, exps, floor


@functools.lru_cache(maxsize=None)
def hidden_diagnosis(name):
    base, _, exps, _ = hidden_case(name)
    return diagnose(base, exps)


def describe(d, floor=None):
    """Diagnostic text printed in assertion messages: verdict, score pass and refits."""
    lines = [f"verdict={d.verdict!r}; message={d.message}"]
    if floor is not None:
        lines.append(f"noise floor {floor:.6f}, error before {d.error_before.overall:.6f}")
    lines.append("score pass: " + ", ".join(
        f"{s['effect']}(LM={s['lm']:.1f})" for s in d.score_pass if "lm" in s))
    for c in d.ranking:
        params = ", ".join(f"{k}={v['value']:.4g}±{v['stderr']:.2g}" for k, v in c["params"].items())
        lines.append(f"  {c['effect']}: err after {c['error_after_overall']:.6f}, "
                     f"dBIC {c['delta_bic']:.1f}, p {c['p_value']:.3g}, "
                     f"drop {c['relative_drop']:.3f}; {params}")
    return "\n".join(lines)


# ----------------------------------------------------------------- the cases themselves

def test_every_catalog_effect_has_a_hidden_case():
    assert set(BUILTIN) == set(HIDDEN)


@pytest.mark.parametrize("name", BUILTIN)
def test_hidden_strength_is_valid_and_not_the_probe(name):
    eff = EFFECTS[name]
    vals = HIDDEN[name]
    assert set(vals) == {p.name for p in eff.parameters}
    for p in eff.parameters:
        assert p.min <= vals[p.name] <= p.max, p.name
    probe = eff.probe_values()
    for p in eff.score_params:
        # at least 10 % away from the probe value, so that the refit has to move
        assert abs(vals[p] - probe[p]) > 0.1 * abs(probe[p]), p
    # the truth is a valid model (applicability, bounds)
    Model.from_dict(truth_model(name))


@pytest.mark.parametrize("name", BUILTIN)
def test_hidden_effect_is_named_first(name):
    d = hidden_diagnosis(name)
    floor = hidden_case(name)[3]
    assert d.verdict == name, describe(d, floor)
    assert d.ranking and d.ranking[0]["effect"] == name, describe(d, floor)


@pytest.mark.parametrize("name", BUILTIN)
def test_error_after_adding_the_effect_is_at_the_noise_floor(name):
    base, _, exps, floor = hidden_case(name)
    d = hidden_diagnosis(name)
    cand = {c["effect"]: c for c in d.ranking}.get(name)
    assert cand is not None, describe(d, floor)
    assert cand["error_after_overall"] <= FLOOR_FACTOR * floor, describe(d, floor)
    # the effect was material: the base model was clearly worse than the floor
    assert d.error_before.overall > 1.2 * floor, describe(d, floor)
    # the next model version reproduces the refit's error (apply_diagnosis returns that model)
    nxt = apply_diagnosis(base, d, effect=name)
    assert name in nxt.effects
    err = compare(nxt, exps).overall
    # same model, same data: identical up to round-off
    assert err == pytest.approx(cand["error_after_overall"], rel=1e-9)


@pytest.mark.parametrize("name", BUILTIN)
def test_refitted_parameters_match_the_truth(name):
    d = hidden_diagnosis(name)
    cand = {c["effect"]: c for c in d.ranking}.get(name)
    assert cand is not None, describe(d)
    eff = EFFECTS[name]
    # the parameters acting on this model (a valve without a rest position has nowhere for a
    # switching delay's off_time to return to: it is not fitted)
    acting = [p for p in eff.diagnosis_params
              if p not in eff.unused_in(Model.from_dict(base_model(name)))]
    assert set(cand["params"]) == set(acting)
    for p in acting:
        v = cand["params"][p]
        want = truth_value(name, p)
        assert abs(v["value"] - want) <= PARAM_RTOL * abs(want), (p, v, want, describe(d))
        assert v["unit"] == eff.param(p).unit
        lo, hi = v["ci95"]
        assert lo <= v["value"] <= hi
        assert math.isfinite(v["stderr"]) and v["stderr"] >= 0.0


# ----------------------------------------------------------------- controls

@pytest.mark.parametrize("base_kind", ["paper-4way", "adiabatic-constant-friction"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_hidden_effect_gives_no_verdict(base_kind, seed):
    """The true model is diagnosed on its own data: nothing is missing.

    ``paper-4way`` (convective, pressure/quadrant friction) offers 8 candidates;
    the adiabatic constant-friction base offers all 11 (and is itself the truth).
    """
    m = model_preset("paper-4way")
    if base_kind == "adiabatic-constant-friction":
        m["heat"]["model"] = "adiabatic"
        m["friction"] = {"extend": dict(CONSTANT_SYMMETRIC_FRICTION),
                         "retract": dict(CONSTANT_SYMMETRIC_FRICTION)}
    exps = synthetic_experiments(m, seed=seed)
    d = diagnose(m, exps)
    assert d.verdict is None, describe(d)
    assert d.message.startswith("no catalog effect explains")
    with pytest.raises(ValueError, match="named no effect"):
        apply_diagnosis(m, d)


PAIRS = [
    ({"piston_leakage": HIDDEN["piston_leakage"]},
     {"valve_spool_dynamics": HIDDEN["valve_spool_dynamics"]}),
    ({"sensor_lag": HIDDEN["sensor_lag"]},
     {"dead_volume": HIDDEN["dead_volume"]}),
]


@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: "+".join(list(p[0]) + list(p[1])))
def test_two_hidden_effects_are_found_in_two_rounds(pair):
    first, second = pair
    hidden = {**first, **second}
    base = model_preset("paper-4way")
    truth = model_preset("paper-4way")
    truth["effects"] = {k: dict(v) for k, v in hidden.items()}
    exps = synthetic_experiments(truth, seed=3)
    floor = compare(truth, exps).overall

    d1 = diagnose(base, exps)
    assert d1.verdict in hidden, describe(d1, floor)
    m1 = apply_diagnosis(base, d1)
    assert set(m1.effects) == {d1.verdict}

    d2 = diagnose(m1, exps)
    other = (set(hidden) - {d1.verdict}).pop()
    assert d2.verdict == other, describe(d2, floor)
    m2 = apply_diagnosis(m1, d2)
    assert set(m2.effects) == set(hidden)

    final = compare(m2, exps).overall
    assert final <= FLOOR_FACTOR * floor, (final, floor, m2.effects)
    # every refitted parameter of both effects is recovered (the second round refits the first
    # effect's parameters too, since they were fitted on a model missing the second effect)
    for name, vals in hidden.items():
        for p in EFFECTS[name].diagnosis_params:
            got = m2.effects[name][p]
            assert abs(got - vals[p]) <= PARAM_RTOL * abs(vals[p]), (name, p, got, vals[p])

    # and a third round finds nothing more (no spurious third effect)
    d3 = diagnose(m2, exps)
    assert d3.verdict is None, describe(d3, floor)


# ----------------------------------------------------------------- report, options

def test_to_dict_is_json_with_the_documented_keys():
    d = hidden_diagnosis("piston_leakage")
    out = d.to_dict()
    text = json.dumps(out, allow_nan=False)   # strict JSON: no NaN/Infinity tokens
    back = json.loads(text)
    for key in ("verdict", "ranking", "error_before", "failure_windows", "residual_tests"):
        assert key in back, key
    assert back["verdict"] == "piston_leakage"
    assert back["ranking"]
    for c in back["ranking"]:
        for key in ("effect", "error_after", "delta_bic", "p_value", "params", "explanation"):
            assert key in c, key
        assert "model_obj" not in c
        assert isinstance(c["explanation"], str) and c["effect"] in c["explanation"]
        for p in c["params"].values():
            assert {"value", "stderr", "ci95", "unit"} <= set(p)
    assert {"errors", "overall"} <= set(back["error_before"])
    for w in back["failure_windows"]:
        assert isinstance(w["description"], str) and w["description"]
    assert {"tests", "structure_remains", "summary"} <= set(back["residual_tests"])
    # the base model's residual on piston-leak data is not white
    assert back["residual_tests"]["structure_remains"] is True


def test_candidates_restrict_the_search():
    base, _, exps, _ = hidden_case("piston_leakage")
    allowed = ["sensor_lag", "piston_leakage", "dead_volume"]
    d = diagnose(base, exps, candidates=allowed)
    assert d.verdict == "piston_leakage", describe(d)
    assert {s["effect"] for s in d.score_pass} <= set(allowed)
    assert {c["effect"] for c in d.ranking} <= set(allowed)


def test_candidate_already_in_the_model_is_skipped():
    base, _, exps, _ = hidden_case("piston_leakage")
    # paper-4way is convective already: heat exchange cannot be added
    d = diagnose(base, exps, candidates=["heat_exchange"])
    assert d.verdict is None
    assert d.ranking == []
    (entry,) = d.score_pass
    assert entry["effect"] == "heat_exchange" and "convective" in entry["skipped"]


def test_unknown_candidate_raises_naming_its_index():
    base, _, exps, _ = hidden_case("piston_leakage")
    with pytest.raises(ValueError, match=r"candidates\[1\]"):
        diagnose(base, exps, candidates=["piston_leakage", "no_such_effect"])


def test_uncertain_base_parameter_is_refitted_with_the_effect():
    """Truth: h = 25 W/(m^2 K) and a piston leak; the base has h = 15 and no leak."""
    truth = model_preset("paper-4way")
    truth["effects"] = {"piston_leakage": dict(HIDDEN["piston_leakage"])}
    base = model_preset("paper-4way")
    base["heat"]["coefficient"] = 15.0
    exps = synthetic_experiments(truth, seed=5)
    floor = compare(truth, exps).overall

    d = diagnose(base, exps, uncertain=["heat.coefficient"])
    assert d.verdict == "piston_leakage", describe(d, floor)
    assert d.uncertain == ["heat.coefficient"]
    best = d.ranking[0]
    # the coefficient is refitted jointly with the leak; 5 %: the locked hold test pins h to
    # a fraction of a percent once the leak is modelled (15 -> 25 is a 40 % correction)
    h = best["uncertain_params"]["heat.coefficient"]["value"]
    assert h == pytest.approx(25.0, rel=0.05), describe(d, floor)
    g = best["params"]["conductance"]["value"]
    assert abs(g - 1.5e-10) <= PARAM_RTOL * 1.5e-10, describe(d, floor)
    assert best["error_after_overall"] <= FLOOR_FACTOR * floor, describe(d, floor)
    nxt = apply_diagnosis(base, d)
    assert nxt.heat.coefficient == pytest.approx(h, rel=1e-12)
    assert nxt.effects["piston_leakage"]["conductance"] == pytest.approx(g, rel=1e-12)
