"""Heat models by name: the registry drives the core; conservation, limits and equivalences.

Oracles: energy conservation of a closed chamber with its wall (first law),
the first-order response of a sensor (the exact exponential filter of the
simulated gas temperature), the large-Rayleigh limit of the Churchill-Chu
correlation (h ~ Ra^(1/3) ~ p^(2/3)), equalities between two routes to the same
physics (a heat model and the catalog effect that adds the same term), and the
end state of a chamber emptied into a vacuum line (its pressure).
"""
import math

import numpy as np
import pytest

from pneucore import EFFECTS, FieldError, model_preset, simulate
from pneucore.physics.gas import cv
from pneucore.physics.heat import (HEAT_MODELS, HEAT_PARAMETERS, churchill_chu_cylinder_nusselt,
                           jet_convection_coefficient, natural_convection_coefficient)
from pneucore.description.model import Model
from pneucore.description.paths import get_value, parse_parameters
from pneucore.physics.vessel import orifice_conductance, vessel_model

HOLD = {"duration": 2.0, "sample_period": 1e-3, "command": [[0.0, 0.0]], "locked": True,
        "x0": 0.125, "initial": {"p_a": 5e5, "T_a": 350.0, "p_b": 2e5, "T_b": 300.0}}


def jack(heat):
    m = model_preset("paper-4way")
    m["heat"] = heat
    return m


# ------------------------------------------------------------------ registry
def test_every_model_lists_documented_parameters():
    for name, hm in HEAT_MODELS.items():
        d = hm.to_dict()
        assert d["name"] == name and d["description"].strip()
        for p in d["parameters"]:
            assert p["unit"].strip() and p["min"] <= p["default"] <= p["max"], (name, p)
        # the law's docstring carries its equation and its source
        doc = hm.func.__doc__ or ""
        assert doc.strip(), name
    for name in ("convective", "natural_convection", "natural_and_jet"):
        assert "wall_mass" in HEAT_MODELS[name].parameters
        assert "sensor_time_constant" in HEAT_MODELS[name].parameters


def test_old_heat_json_round_trips_unchanged():
    for d in ({"model": "convective", "coefficient": 25.0}, {"model": "isothermal", "coefficient": 3.0},
              {"model": "adiabatic", "coefficient": 25.0}):
        assert Model.from_dict(jack(d)).to_dict()["heat"] == d


def test_model_parameters_validated_by_name():
    with pytest.raises(FieldError) as e:
        Model.from_dict(jack({"model": "convective", "jet_multiplier": 1.0}))
    assert e.value.path == "heat.jet_multiplier"
    with pytest.raises(FieldError) as e:
        Model.from_dict(jack({"model": "natural_convection", "wall_mass": -1.0}))
    assert e.value.path == "heat.wall_mass"
    m = Model.from_dict(jack({"model": "natural_and_jet", "jet_multiplier": 0.5}))
    assert m.to_dict()["heat"]["jet_multiplier"] == 0.5


def test_calibration_paths_carry_the_registry_units_and_bounds():
    m = Model.from_dict(jack({"model": "natural_and_jet"}))
    spec = parse_parameters(m, ["heat.jet_multiplier", "heat.wall_mass"])
    assert (spec[0].unit, spec[0].min, spec[0].max) == ("-", HEAT_PARAMETERS["jet_multiplier"].min,
                                                        HEAT_PARAMETERS["jet_multiplier"].max)
    assert spec[1].unit == "kg"
    with pytest.raises(FieldError) as e:
        get_value(Model.from_dict(jack({"model": "convective"})), "heat.jet_multiplier")
    assert e.value.path == "parameters.heat.jet_multiplier"


# ------------------------------------------------------------------ correlations
def test_natural_convection_follows_the_density_squared():
    """Ra ~ rho^2 ~ p^2 at a given temperature: 8x the pressure doubles Ra^(1/6), so in
    Churchill-Chu's form sqrt(Nu) - 0.6 doubles exactly (h ~ p^(2/3) at large Ra)."""
    from pneucore.physics.gas import air_conductivity
    k = air_conductivity(0.5 * (320.0 + 295.0))
    h1 = natural_convection_coefficient(10e5, 320.0, 295.0, 0.2, 287.05, 1004.7)
    h8 = natural_convection_coefficient(80e5, 320.0, 295.0, 0.2, 287.05, 1004.7)
    # floating-point rounding of powers and square roots only: 1e-12
    assert math.sqrt(h8 * 0.2 / k) - 0.6 == pytest.approx(2.0 * (math.sqrt(h1 * 0.2 / k) - 0.6), rel=1e-12)
    assert 3.5 < h8 / h1 < 4.0     # towards p^(2/3) = 4 as the 0.6 fades
    # no temperature difference: the conduction floor 0.36 k / D, not zero and not NaN
    h0 = natural_convection_coefficient(1e5, 295.0, 295.0, 0.2, 287.05, 1004.7)
    assert h0 == pytest.approx(churchill_chu_cylinder_nusselt(0.0, 0.71) * 0.026 / 0.2, rel=0.02)


def test_jet_term_vanishes_without_inflow():
    assert jet_convection_coefficient(0.0, 3e-3, 300.0, 0.2) == 0.0
    assert jet_convection_coefficient(-1e-3, 3e-3, 300.0, 0.2) == 0.0
    # Nu ~ Re^0.67: twice the flow, 2^0.67 the coefficient (exact: same temperature)
    r = jet_convection_coefficient(2e-3, 3e-3, 300.0, 0.2) / jet_convection_coefficient(1e-3, 3e-3, 300.0, 0.2)
    assert r == pytest.approx(2.0 ** 0.67, rel=1e-12)


# ------------------------------------------------------------------ the core
def test_closed_chamber_and_wall_conserve_energy():
    """Locked, valve centred (overlap: no flow), no outer exchange: the gas's internal energy
    m cv T plus the wall's m_w c_w T_w is constant while the hot gas heats the wall."""
    mw, cw = 0.01, 500.0
    res = simulate(jack({"model": "natural_convection", "wall_mass": mw, "wall_specific_heat": cw,
                         "outer_coefficient": 0.0, "natural_multiplier": 5.0}), HOLD)
    E = res.m_a * cv() * res.T_a + mw * cw * res.series["T_wall_a"]
    drop = res.T_a[0] - res.T_a[-1]
    assert drop > 5.0                        # the exchange did something
    # relative to the energy moved (m cv dT): the solver's rtol 1e-5 on both states, x10
    assert np.max(np.abs(E - E[0])) < 1e-4 * res.m_a[0] * cv() * drop
    assert np.all(np.diff(res.series["T_wall_a"]) >= -1e-9)   # the wall only warms


def test_jet_model_equals_natural_model_without_inflow():
    a = simulate(jack({"model": "natural_convection"}), HOLD)
    b = simulate(jack({"model": "natural_and_jet"}), HOLD)
    for k in ("p_a", "T_a", "p_b", "T_b"):
        assert np.array_equal(a.series[k], b.series[k]), k


def test_temperature_sensor_is_a_first_order_filter_of_the_gas_temperature():
    tau = 0.05
    res = simulate(jack({"model": "natural_convection", "natural_multiplier": 5.0,
                         "sensor_time_constant": tau}), {**HOLD, "solver": {"rtol": 1e-9}})
    t, T, Ts = res.t, res.T_a, res.observed("T_a")
    assert Ts is res.series["T_a_sensor"]
    # exact exponential filter of the sampled T (piecewise linear between 1 ms samples)
    ref = np.empty_like(T)
    ref[0] = T[0]
    for i in range(1, len(t)):
        h = t[i] - t[i - 1]
        e = math.exp(-h / tau)
        slope = (T[i] - T[i - 1]) / h
        ref[i] = T[i] - slope * tau + (ref[i - 1] - T[i - 1] + slope * tau) * e
    # the reference filters T linearly interpolated between samples: its error is at most that
    # of the interpolation, h^2/8 max|T''| (T'' from second differences, x2 for their own error),
    # the solver's (rtol 1e-9 of 350 K) far below it
    h = t[1] - t[0]
    bound = 2.0 * h * h / 8.0 * np.max(np.abs(np.diff(T, 2))) / (h * h)
    assert np.max(np.abs(Ts - ref)) < bound + 1e-6
    assert np.max(np.abs(Ts - T)) > 0.1     # the lag is visible


def test_heat_model_and_catalog_effect_give_the_same_core():
    """Two routes to the same physics: a heat model's term, or the catalog effect adding it."""
    a = simulate(jack({"model": "natural_convection"}), HOLD)
    m = jack({"model": "adiabatic"})
    m["effects"] = {"natural_convection": {"multiplier": 1.0}}
    b = simulate(m, HOLD)
    assert np.array_equal(a.T_a, b.T_a) and np.array_equal(a.p_a, b.p_a)
    a = simulate(jack({"model": "convective", "wall_mass": 0.02}), HOLD)
    m = jack({"model": "convective"})
    m["effects"] = {"wall_heat_capacity": {"mass": 0.02}}
    b = simulate(m, HOLD)
    assert np.array_equal(a.T_a, b.T_a) and np.array_equal(a.series["T_wall_a"], b.series["T_wall_a"])


def test_heat_effects_refuse_what_the_model_already_has():
    m = jack({"model": "natural_and_jet"})
    for name in ("natural_convection", "inflow_jet_convection"):
        m["effects"] = {name: {}}
        with pytest.raises(FieldError) as e:
            Model.from_dict(m)
        assert e.value.path == f"effects.{name}"
    m = jack({"model": "isothermal"})
    m["effects"] = {"wall_heat_capacity": {}}
    with pytest.raises(FieldError):
        Model.from_dict(m)
    assert {"natural_convection", "inflow_jet_convection", "wall_heat_capacity"} <= set(EFFECTS)


# ------------------------------------------------------------------ sources at or below ambient
def _vessel(p_src, heat=None):
    return vessel_model(0.01, 0.2, 0.3, 2e-3, 0.8, p_src, 295.0, heat)


def test_vessel_filled_from_the_atmosphere_reaches_it():
    res = simulate(_vessel(1e5, {"model": "convective", "coefficient": 10.0}),
                   {"duration": 60.0, "sample_period": 0.1, "command": [[0.0, 1.0]], "locked": True,
                    "x0": 0.0, "initial": {"p_a": 5e3, "T_a": 295.0}})
    # the end state: the source's pressure (laminar branch near r = 1: 1e-5 relative after 60 s)
    assert res.p_a[-1] == pytest.approx(1e5, rel=1e-4)
    assert res.T_a.max() > 300.0             # the inflow heats the gas (enthalpy cp T_0 > cv T)


def test_chamber_emptied_into_a_vacuum_line_reaches_its_pressure():
    m = jack({"model": "convective", "coefficient": 25.0})
    m["supply"] = {"pressure": 0.2e5, "temperature": 293.15}
    res = simulate(m, {"duration": 3.0, "sample_period": 1e-2, "command": [[0.0, 1.0]],
                       "locked": True, "x0": 0.125, "initial": {"p_a": 1.013e5}})
    assert res.p_a[-1] == pytest.approx(0.2e5, rel=1e-3)   # rel 1e-3: laminar tail after 3 s
    assert np.all(np.diff(res.p_a) <= 1e-6 * 1e5)             # it only empties


def test_sources_where_the_physics_does_not_hold_are_named():
    m = jack({"model": "convective"})
    m["supply"] = {"pressure": 300.0}
    with pytest.raises(FieldError) as e:
        Model.from_dict(m)
    assert e.value.path == "supply.pressure" and "continuum" in str(e.value)
    m3 = model_preset("paper-3way")
    m3["supply"] = {"pressure": 0.3e5}
    with pytest.raises(FieldError) as e:
        Model.from_dict(m3)
    assert e.value.path == "valve.b_chamber_pressure"
    m3["valve"]["b_chamber_pressure"] = 1e5
    Model.from_dict(m3)


def test_orifice_conductance_matches_the_nozzle_choked_flow():
    """C rho_0 p sqrt(T_0/T) (ISO 6358 choked) equals Cd A p sqrt(gamma/(r T)) (2/(g+1))^((g+1)/(2(g-1)))."""
    from pneucore.physics.gas import GAMMA_AIR as g, R_AIR as r, RHO_REF, T_REF
    d, Cd, p, T = 2.71e-3, 0.84, 1e5, 295.0
    iso = orifice_conductance(d, Cd) * RHO_REF * p * math.sqrt(T_REF / T)
    nozzle = Cd * math.pi * d * d / 4 * p * math.sqrt(g / (r * T)) * (2 / (g + 1)) ** ((g + 1) / (2 * (g - 1)))
    assert iso == pytest.approx(nozzle, rel=1e-12)


@pytest.mark.parametrize("module", ["pneucore.physics.heat", "pneucore.physics.gas", "pneucore.physics.vessel"])
def test_worked_examples_in_the_docstrings(module):
    """The docstrings' examples (Churchill-Chu, Sutherland against the tables, Eq. 9, the
    orifice's conductance) run as doctests."""
    import doctest
    import importlib
    res = doctest.testmod(importlib.import_module(module))
    assert res.attempted > 0 and res.failed == 0
