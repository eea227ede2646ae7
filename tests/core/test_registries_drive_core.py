"""The law registries drive the compiled core: a flow or friction law registered at run
time and named in the model is what :func:`pneucore.simulate` computes with; removing
it restores the built-in core; an unknown law name is a FieldError naming the field.

One module fixture registers both test laws, then runs the base model, the model
naming the flow law and the model naming the friction law: the two runs with a
registered law share one specialised core (compiled in memory once, ~10 s), the
base runs use the core numba caches on disk.
"""
import math

import numpy as np
import pytest
from numba import njit

import pneucore
from pneucore import FieldError, Model, model_preset, scenario_preset, simulate
from pneucore.core import integrator, rhs
from pneucore.physics.flow import FLOW_LAWS, iso6358_mass_flow, register_flow_law, unregister_flow_law
from pneucore.physics.friction import (FRICTION_LAWS, breakaway_friction, coulomb_level,
                                       register_friction_law, sliding_friction,
                                       unregister_friction_law, viscous_coefficient)

FLOW_NAME = "test_double_iso6358"
FRICTION_NAME = "test_double_coulomb"


@njit
def double_iso(p1, T1, p2, T2, C, b, m, r_lam, r, gamma):
    return 2.0 * iso6358_mass_flow(p1, T1, p2, T2, C, b, m, r_lam, r, gamma)


@njit
def double_force(v, direction, fc, kv, ratio, v_s):
    return 2.0 * sliding_friction(v, direction, fc, kv, ratio, v_s)


@njit
def double_static(fc, ratio, v_s):
    return 2.0 * breakaway_friction(fc, ratio, v_s)


def scenario(duration=0.4):
    s = scenario_preset("paper-fig10-pulses")
    s["duration"] = duration
    return s


def with_laws(flow=None, friction=None):
    m = model_preset("paper-4way")
    if flow:
        m["valve"]["flow_law"] = flow
    if friction:
        m["friction"]["law"] = friction
    return m


def filling():
    """Locked jack, valve opened to 0.7 at t = 0: chamber A fills through edge P-A alone."""
    s = scenario(0.01)
    s.update(command=[[0.0, 0.7]], locked=True)
    return s


@pytest.fixture(scope="module")
def runs():
    builtin_flow, builtin_friction = dict(FLOW_LAWS), dict(FRICTION_LAWS)
    out = {"base": simulate(with_laws(), scenario()),
           "base_fill": simulate(with_laws(), filling())}
    flow_law = register_flow_law(FLOW_NAME, double_iso, "2 x ISO 6358 (test)")
    friction_law = register_friction_law(FRICTION_NAME, double_force, double_static,
                                         "2 x Eq. 18 (test)")
    try:
        out["flow_code"], out["friction_code"] = flow_law.code, friction_law.code
        out["flow_fill"] = simulate(with_laws(flow=FLOW_NAME), filling())
        out["friction"] = simulate(with_laws(friction=FRICTION_NAME), scenario())
        # validated while the laws were registered, simulated after they are gone
        out["stale"] = Model.from_dict(with_laws(flow=FLOW_NAME, friction=FRICTION_NAME))
        out["specialised"] = len(integrator._SPECIALIZED)
    finally:
        unregister_flow_law(FLOW_NAME)
        unregister_friction_law(FRICTION_NAME)
    out["registries_restored"] = (FLOW_LAWS == builtin_flow and FRICTION_LAWS == builtin_friction)
    out["after"] = simulate(with_laws(), scenario())
    return out


def test_builtin_tables_come_from_the_registries():
    # the core cached on disk dispatches over the registries' built-in entries, by code
    assert rhs.flow_laws == tuple((law.code, law.func) for law in
                                  sorted(FLOW_LAWS.values(), key=lambda law: law.code))
    assert dict(rhs.flow_laws)[FLOW_LAWS["saint_venant"].code] is pneucore.saint_venant_mass_flow
    assert rhs.friction_laws == ((0, sliding_friction, breakaway_friction),)
    assert FRICTION_LAWS["coulomb_viscous"].code == 0


def test_registered_flow_law_is_computed(runs):
    base, new = runs["base_fill"], runs["flow_fill"]
    assert runs["flow_code"] not in {law.code for law in FLOW_LAWS.values()}
    # t = 0: same state, edge P-A open, A-R closed: q_a is the P-A flow, exactly doubled
    # (a product by 2 is exact in binary floating point; 1e-12 allows a summation order)
    assert base.q_a[0] > 0.0
    assert new.q_a[0] == pytest.approx(2.0 * base.q_a[0], rel=1e-12)
    # twice the flow fills chamber A faster
    i = np.searchsorted(base.t, 0.005)
    assert new.p_a[i] > base.p_a[i] + 1e4


def test_registered_friction_law_is_computed(runs):
    base, new = runs["base"], runs["friction"]
    # twice the static limit: the piston breaks away later
    assert new.events_of("slip")[0] > base.events_of("slip")[0]
    # while sliding, the friction output is the registered law at the run's own state
    fr = model_preset("paper-4way")["friction"]
    p_atm = model_preset("paper-4way")["ambient"]["pressure"]
    sliding = np.flatnonzero((new.mode == "slide") & (np.abs(new.v) > 1e-3))
    assert sliding.size > 20
    for i in sliding:
        s = fr["extend"] if new.v[i] > 0 else fr["retract"]
        fc = coulomb_level(s["fc0"], s["fc_a"], s["fc_b"], new.p_a[i], new.p_b[i], p_atm)
        kv = viscous_coefficient(s["kv0"], s["kv_a"], s["kv_b"], new.p_a[i], new.p_b[i], p_atm)
        expected = 2.0 * (kv * new.v[i] + math.copysign(fc, new.v[i]))
        # the same formula as the core's on the same doubles, up to rounding in its order
        assert new.friction[i] == pytest.approx(expected, rel=1e-9)


def test_one_specialised_core_for_both_laws(runs):
    # both registered laws are compiled into one core, so registering two laws costs one compile
    assert runs["specialised"] >= 1
    key = [k for k in integrator._SPECIALIZED if k[0] is rhs.no_terms]
    tables = {(len(k[1]), len(k[2])) for k in key}
    assert (len(rhs.flow_laws) + 1, len(rhs.friction_laws) + 1) in tables


def test_unregistering_restores(runs):
    assert runs["registries_restored"]
    assert integrator.core_for(rhs.no_terms, rhs.law_table(FLOW_LAWS),
                               rhs.law_table(FRICTION_LAWS)) is integrator.integrate
    # exact: the same cached core on the same inputs
    for k in ("p_a", "p_b", "x", "v", "friction"):
        assert np.array_equal(runs["after"].series[k], runs["base"].series[k])


def test_unknown_law_names_the_field(runs):
    with pytest.raises(FieldError) as e:
        Model.from_dict(with_laws(flow="no_such_law"))
    assert e.value.path == "valve.flow_law"
    with pytest.raises(FieldError) as e:
        Model.from_dict(with_laws(friction="no_such_law"))
    assert e.value.path == "friction.law"
    # a model validated while its law was registered, simulated after it was removed
    with pytest.raises(FieldError) as e:
        simulate(runs["stale"], scenario(0.01))
    assert e.value.path == "valve.flow_law"


def test_registration_rules():
    with pytest.raises(ValueError, match="built-in"):
        register_flow_law("iso6358", double_iso, replace=True)
    with pytest.raises(ValueError, match="built-in"):
        unregister_friction_law("coulomb_viscous")
    with pytest.raises(TypeError):
        register_flow_law("test_not_a_function", 3.0)
    law = register_flow_law(FLOW_NAME, double_iso)
    try:
        with pytest.raises(ValueError, match="already registered"):
            register_flow_law(FLOW_NAME, double_iso)
        # replacing keeps the code; a plain Python law is compiled on registration
        again = register_flow_law(FLOW_NAME, double_iso.py_func, replace=True)
        assert again.code == law.code and hasattr(again.func, "py_func")
        assert again(5e5, 293.15, 1e5, 293.15, 1e-8, 0.3) == pytest.approx(
            2.0 * FLOW_LAWS["iso6358"](5e5, 293.15, 1e5, 293.15, 1e-8, 0.3), rel=1e-15)
    finally:
        unregister_flow_law(FLOW_NAME)
    assert FLOW_NAME not in FLOW_LAWS
    # a friction law given only its force gets its static limit from the force at v = 0
    law = register_friction_law(FRICTION_NAME, double_force)
    try:
        assert law.static(40.0, 1.5, 0.01) == pytest.approx(2.0 * 40.0 * 1.5, rel=1e-15)
    finally:
        unregister_friction_law(FRICTION_NAME)


def test_specialised_core_re_creates_every_function_on_the_way():
    # found from the code: every compiled function that reaches a rebound name (user hook,
    # law tables) is cloned, so none of them silently calls the default core's right-hand side
    rhs_chain = integrator._chain(vars(rhs), rhs.__name__, integrator._REBOUND)
    assert {"rhs", "edge_flow", "_edge", "friction_force", "static_friction",
            "call_user_terms"} <= set(rhs_chain)
    core_chain = integrator._chain(vars(integrator), integrator.__name__, {"rhs", "static_friction"})
    assert {"integrate", "_feval", "_rodas_step", "_jacobian", "_rest_forces", "_locate_event",
            "_back_step", "_event_at", "_settle", "_transition"} <= set(core_chain)
    # functions that reach none of them are loaded from numba's cache, not recompiled
    assert "command_segment" not in core_chain and "_hermite" not in core_chain
