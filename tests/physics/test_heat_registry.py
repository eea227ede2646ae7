"""Registering a heat model changes what the core computes (the registry drives the core).

A heat model is a choice of the terms of the core's law ``h = h_0 + c_n h_nat + c_j h_jet``
(pneucore/physics/heat.py); a model registered with both the fixed coefficient of Eq. 9
and natural convection exchanges more heat than either alone, so the gas temperature of
the paper's pulse test strays less from the wall's. Physics, not a number made up here:
with more exchange the compression heating and expansion cooling are smaller.
"""
import numpy as np
import pytest

from pneucore import model_preset, scenario_preset, simulate
from pneucore.physics.heat import (HEAT_MODELS, convective_heat_flow, register_heat_model,
                                   unregister_heat_model)
from pneucore.description.model import Model
from pneucore.description.validation import FieldError

NAME = "test_fixed_and_natural"


def _model(heat):
    m = model_preset("paper-4way")
    m["heat"] = heat
    return m


def _excursion(res):
    """Largest gas-temperature excursion from the ambient temperature in either chamber [K]."""
    return float(max(np.max(np.abs(res.T_a - 293.15)), np.max(np.abs(res.T_b - 293.15))))


@pytest.fixture
def registered():
    register_heat_model(NAME, convective_heat_flow, "Eq. 9 plus natural convection (test)",
                        ("coefficient", "natural_multiplier"), fixed=True, natural=True)
    yield
    unregister_heat_model(NAME)


def test_a_registered_model_changes_the_simulation(registered):
    scen = scenario_preset("paper-fig10-pulses")
    scen["duration"] = 0.6
    fixed = simulate(_model({"model": "convective", "coefficient": 25.0}), scen)
    natural = simulate(_model({"model": "natural_convection", "natural_multiplier": 1.0}), scen)
    both = simulate(_model({"model": NAME, "coefficient": 25.0, "natural_multiplier": 1.0}), scen)
    # more exchange, smaller excursion: strictly below each term alone (a 1 mK margin is far
    # above the solver's tolerance on T, ~1e-5 relative, and far below the ~K effects here)
    assert _excursion(both) < _excursion(fixed) - 1e-3
    assert _excursion(both) < _excursion(natural) - 1e-3
    assert not np.allclose(both.p_a, fixed.p_a, rtol=1e-6)


def test_registered_model_is_listed_and_validated(registered):
    m = Model.from_dict(_model({"model": NAME, "coefficient": 30.0}))
    assert m.heat.model == NAME and m.heat.coefficient == 30.0
    assert HEAT_MODELS[NAME].to_dict()["name"] == NAME
    with pytest.raises(FieldError) as e:   # a parameter the model does not expose
        Model.from_dict(_model({"model": NAME, "jet_multiplier": 2.0}))
    assert "heat" in e.value.path


def test_unregistered_model_is_refused_by_field():
    assert NAME not in HEAT_MODELS
    with pytest.raises(FieldError) as e:
        Model.from_dict(_model({"model": NAME}))
    assert e.value.path == "heat.model"


@pytest.mark.parametrize("kw, msg", [
    (dict(name="convective"), "built-in"),
    (dict(parameters=("no_such",)), "unknown heat parameters"),
    (dict(natural=True, parameters=("coefficient",)), "natural_multiplier"),
    (dict(isothermal=True, fixed=True), "isothermal"),
])
def test_registration_rules(kw, msg):
    args = dict(name=NAME, func=convective_heat_flow, description="x", parameters=("coefficient",),
                fixed=True)
    args.update(kw)
    with pytest.raises(ValueError, match=msg):
        register_heat_model(**args)
    assert NAME not in HEAT_MODELS


def test_builtin_models_cannot_be_removed():
    with pytest.raises(ValueError, match="built-in"):
        unregister_heat_model("convective")
    assert "convective" in HEAT_MODELS
