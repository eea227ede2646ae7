"""Catalog effects: off values reproduce the base model, defaults change it; user effects.

Run on ``paper-4way`` + ``paper-fig10-pulses``. "Reproduces the base model"
is checked with exact equality (``np.array_equal`` on every series, equal
event lists): an effect at its off value either leaves the parameter vector
and state vector untouched (leak conductances 0, no spool/sensor/supply
states) or adds exact zeros (``+ 0.0`` volume or friction coefficient,
``h = 0`` giving ``0 * S * dT``), so the compiled core performs the same
floating-point operations in the same order and the results are bit-identical.
"""
import json

import numpy as np
import pytest
from numba import njit

import pneucore
from pneucore import EFFECTS, Effect, FieldError, Parameter, model_preset, scenario_preset, simulate

#: Effects whose off value only reproduces the base when the base has no such feature already:
#: heat exchange on a non-convective model, pressure/quadrant friction on constant symmetric friction
CONSTANT_SYMMETRIC_FRICTION = {"fc0": 8.0, "fc_a": 0.0, "fc_b": 0.0, "kv0": 40.0, "kv_a": 0.0,
                               "kv_b": 0.0}
#: Effects whose catalog defaults equal their off values (default = switched off): a non-zero
#: setting used instead to check that the effect does something
NONZERO_OVERRIDE = {
    "pressure_dependent_friction": {"fc_a": 2e-5, "fc_b": 1e-5, "kv_a": 5e-5, "kv_b": 3e-5},
    "quadrant_friction": {"fc0": 5.0, "kv0": 20.0},
    "dead_volume": {"volume_a": 2e-5, "volume_b": 2e-5},
    # the pulse test keeps the piston between 40 and 168 mm: cushions that reach into that range
    # (the catalog's 15 mm act on full strokes only, tests/physics/test_cushion.py)
    "end_cushion": {"length_a": 0.12, "length_b": 0.12},
}
#: Smallest change counted as "measurable", as a fraction of full scale (stroke for x, supply for
#: pressures): 20x the solver's default rtol 1e-5, so integration noise alone cannot reach it
MEASURABLE = 2e-4

BUILTIN = sorted(EFFECTS)
SCENARIO = "paper-fig10-pulses"


def base_model(effect_name=None):
    m = model_preset("paper-4way")
    if effect_name == "heat_exchange":
        m["heat"]["model"] = "adiabatic"
    if effect_name in ("pressure_dependent_friction", "quadrant_friction"):
        m["friction"] = {"extend": dict(CONSTANT_SYMMETRIC_FRICTION),
                         "retract": dict(CONSTANT_SYMMETRIC_FRICTION)}
    return m


def off_params(effect):
    """Every parameter at its off value; parameters without one (off=None) at their default."""
    return {p.name: (p.off if p.off is not None else p.default) for p in effect.parameters}


def with_effect(model, name, params):
    m = dict(model)
    m["effects"] = {name: params}
    return m


def assert_identical(res, base):
    assert set(res.series) == set(base.series)
    for k in base.series:
        assert np.array_equal(res.series[k], base.series[k]), k
    assert res.events == base.events
    assert res.stats["steps"] == base.stats["steps"]


def change(res, base, stroke=0.25, supply=7e5):
    """Largest change of x, p_a, p_b and the observed (sensor) pressures, as a fraction of full scale."""
    return max(np.max(np.abs(res.x - base.x)) / stroke,
               np.max(np.abs(res.p_a - base.p_a)) / supply,
               np.max(np.abs(res.p_b - base.p_b)) / supply,
               np.max(np.abs(res.observed("p_a") - base.p_a)) / supply,
               np.max(np.abs(res.observed("p_b") - base.p_b)) / supply)


_BASE_CACHE = {}


def base_result(effect_name=None):
    key = effect_name if effect_name in ("heat_exchange", "pressure_dependent_friction",
                                         "quadrant_friction") else None
    if key not in _BASE_CACHE:
        _BASE_CACHE[key] = simulate(base_model(key), scenario_preset(SCENARIO))
    return _BASE_CACHE[key]


# ----------------------------------------------------------------- catalog listing

@pytest.mark.parametrize("name", BUILTIN)
def test_catalog_entry_is_documented(name):
    e = EFFECTS[name]
    assert e.name == name
    for attr in ("description", "signature", "reference"):
        assert isinstance(getattr(e, attr), str) and getattr(e, attr).strip(), attr
    assert e.parameters
    for p in e.parameters:
        assert isinstance(p, Parameter)
        assert isinstance(p.name, str) and p.name
        assert isinstance(p.unit, str) and p.unit
        for v in (p.default, p.min, p.max):
            assert isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)
        assert p.min <= p.default <= p.max, p.name
        assert p.off is None or p.min <= p.off <= p.max, p.name
    d = e.to_dict()
    json.dumps(d, allow_nan=False)
    assert {"name", "description", "signature", "reference", "parameters"} <= set(d)
    for pd in d["parameters"]:
        assert {"name", "unit", "default", "min", "max", "off"} <= set(pd)
    assert not e.user


def test_catalog_contents():
    assert {"heat_exchange", "piston_leakage", "external_leakage", "valve_spool_dynamics",
            "valve_null_leakage", "stribeck_friction", "pressure_dependent_friction",
            "quadrant_friction", "dead_volume", "supply_pressure_drop", "sensor_lag"} <= set(EFFECTS)


# ----------------------------------------------------------------- off reproduces the base

@pytest.mark.parametrize("name", BUILTIN)
def test_effect_off_reproduces_base(name):
    base = base_result(name)
    model = with_effect(base_model(name), name, off_params(EFFECTS[name]))
    res = simulate(model, scenario_preset(SCENARIO))
    assert res.model.effects == {name: off_params(EFFECTS[name])}
    assert_identical(res, base)


# ----------------------------------------------------------------- defaults change the result

@pytest.mark.parametrize("name", BUILTIN)
def test_effect_on_changes_result(name):
    e = EFFECTS[name]
    params = NONZERO_OVERRIDE.get(name, {})
    if name not in NONZERO_OVERRIDE:
        # the catalog default must switch the effect on
        assert any(p.off is not None and p.default != p.off for p in e.parameters), name
    base = base_result(name)
    res = simulate(with_effect(base_model(name), name, params), scenario_preset(SCENARIO))
    assert res.status == 0
    for k, v in res.series.items():
        if v.dtype.kind == "f":
            assert np.all(np.isfinite(v)), k
    assert change(res, base) > MEASURABLE, name


def test_spool_dynamics_lags_the_command():
    base = base_result()
    res = simulate(with_effect(base_model(), "valve_spool_dynamics", {}), scenario_preset(SCENARIO))
    assert "u_spool" in res.series
    i = np.searchsorted(res.t, 0.185)   # 5 ms into the first pulse (0.18 s, u = 0.7), tau = 5 ms
    assert base.u_eff[i] == 0.7
    assert 0.0 < res.u_eff[i] < 0.7


def test_sensor_lag_is_observed_only():
    res = simulate(with_effect(base_model(), "sensor_lag", {}), scenario_preset(SCENARIO))
    assert "p_a_sensor" in res.series and "p_b_sensor" in res.series
    assert res.observed("p_a") is res.series["p_a_sensor"]
    # the transducer trails the chamber during the first filling
    i = np.searchsorted(res.t, 0.19)
    assert res.p_a_sensor[i] < res.p_a[i]


def test_stribeck_delays_breakaway():
    base = base_result()
    res = simulate(with_effect(base_model(), "stribeck_friction", {}), scenario_preset(SCENARIO))
    assert res.events_of("slip")[0] > base.events_of("slip")[0]


# ----------------------------------------------------------------- user effect

USER_NAME = "test_user_constant_force"


@njit
def constant_force_terms(t, y, sig, p, out, dy, i0):
    out[6] += p[0]   # layout.TERM_NAMES[6] == "force": towards +x [N]


@pytest.fixture(scope="module")
def user_effect_results():
    """Register the user effect, run it with force 0, +20 N and -20 N once, unregister.

    Each run compiles a specialised core in memory (~10 s each), hence module scope.
    """
    assert pneucore.core.layout.TERM_NAMES[6] == "force"
    eff = Effect(name=USER_NAME, description="constant force on the piston",
                 signature="position offset", reference="test",
                 parameters=[Parameter("force", "N", 0.0, -100, 100, 0.0, "force towards +x")],
                 terms=constant_force_terms)
    pneucore.register_effect(eff)
    try:
        listed = EFFECTS.get(USER_NAME)
        out = {"listed": listed}
        base = model_preset("paper-4way")
        for f in (0.0, 20.0, -20.0):
            out[f] = simulate(with_effect(base, USER_NAME, {"force": f}), scenario_preset(SCENARIO))
        with pytest.raises(ValueError):
            pneucore.register_effect(eff)         # the name is taken
    finally:
        pneucore.unregister_effect(USER_NAME)
    return out


def test_user_effect_is_listed(user_effect_results):
    e = user_effect_results["listed"]
    assert e is not None and e.user
    d = e.to_dict()
    assert d["user"] is True and d["parameters"][0]["unit"] == "N"


def test_user_effect_zero_force_reproduces_base(user_effect_results):
    # exact: the specialised core adds a 0.0 force term, which changes no floating-point result
    assert_identical(user_effect_results[0.0], base_result())


def test_user_effect_force_pushes_towards_plus_x(user_effect_results):
    base = base_result()
    plus, minus = user_effect_results[20.0], user_effect_results[-20.0]
    for res in (plus, minus):
        assert res.status == 0
        assert change(res, base) > MEASURABLE
    assert plus.x[-1] > base.x[-1] > minus.x[-1]
    assert plus.x.mean() > base.x.mean() > minus.x.mean()
    # the applied force shows in the net force at t = 0 (same chamber state in all three runs);
    # abs 1e-9 N: round-off of adding 20 N to pressure forces of order p_atm * A ~ 70 N
    assert plus.net_force[0] == pytest.approx(base.net_force[0] + 20.0, abs=1e-9)
    assert minus.net_force[0] == pytest.approx(base.net_force[0] - 20.0, abs=1e-9)


def test_user_effect_unregistered(user_effect_results):
    assert USER_NAME not in EFFECTS
    with pytest.raises(FieldError) as excinfo:
        pneucore.Model.from_dict(with_effect(model_preset("paper-4way"), USER_NAME, {"force": 1.0}))
    assert str(excinfo.value).startswith(f"effects.{USER_NAME}: ")


# ------------------------------------------------------- user effect with a state

CLOCK_NAME = "test_user_clock_state"


@njit
def clock_terms(t, y, sig, p, out, dy, i0):
    # dz/dt = rate, so z(t) = z0 + rate t exactly; the scratch array exercises an
    # allocating user function called from the runtime-free compiled core
    tmp = np.empty(2)
    tmp[0] = p[0]
    tmp[1] = 0.0
    dy[i0] = tmp[0] + tmp[1]


def test_user_effect_state_is_integrated_exactly():
    """A user state with dz/dt = rate is integrated to z = z0 + rate t, sampled with the
    other series, and leaves the base model's series untouched (its terms add nothing)."""
    eff = Effect(name=CLOCK_NAME, description="a clock state", signature="none", reference="test",
                 parameters=[Parameter("rate", "1/s", 0.0, -10, 10, 0.0, "clock rate")],
                 terms=clock_terms, states=("z",), state_units=("s",))
    pneucore.register_effect(eff)
    try:
        res = simulate(with_effect(model_preset("paper-4way"), CLOCK_NAME, {"rate": 2.0}),
                       scenario_preset(SCENARIO))
    finally:
        pneucore.unregister_effect(CLOCK_NAME)
    # a linear state is integrated exactly by RODAS4 and its Hermite interpolant; the
    # only error is rounding in the stage sums over ~200 steps: 1e-12 s of z ~ 2
    np.testing.assert_allclose(res.series["z"], 2.0 * res.t, rtol=0, atol=1e-12)
    # The extra state enters the error norm (one more term in the RMS), which may change
    # the step sequence, so the base series agree to the solver's accuracy, not bit for bit:
    # each run is within ~1e-5 of full scale of the exact solution (the simulator benchmark
    # measures <= 9.2e-6 at the default rtol), so 1e-4 leaves 5x margin over their sum,
    # while any term leaking into the base equations (rate 2 /s) would move them by > 1e-2.
    assert change(res, base_result()) < 1e-4
