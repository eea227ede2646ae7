"""pneucore: physics and numerics of valve-driven pneumatic actuators.

The model is Maré, Geider & Colin, "An improved dynamic model of pneumatic
actuators": ISO 6358 valve edges, chambers from mass and energy
conservation with convective exchange, Coulomb + viscous friction depending
on pressure and quadrant with exact stick/slip. No web framework here.
"""
from pneucore.core import cache as _cache

_cache.check()      # numba's cache must not outlive an edit of any core module

from pneucore.description.effects import EFFECTS, Effect, Parameter, register_effect, unregister_effect
from pneucore.physics.flow import (FLOW_LAWS, iso6358_mass_flow, register_flow_law,
                                   saint_venant_mass_flow, unregister_flow_law)
from pneucore.physics.friction import FRICTION_LAWS, register_friction_law, unregister_friction_law
from pneucore.physics.heat import HEAT_MODELS, register_heat_model, unregister_heat_model
from pneucore.description.model import Model
from pneucore.description.presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset
from pneucore.result import SimulationResult
from pneucore.description.scenario import Scenario, pulse_train
from pneucore.simulate import SimulationError, simulate
from pneucore.description.validation import FieldError

__version__ = "0.1.0"

__all__ = [
    "EFFECTS", "Effect", "Parameter", "register_effect", "unregister_effect", "FLOW_LAWS",
    "iso6358_mass_flow", "saint_venant_mass_flow", "register_flow_law", "unregister_flow_law",
    "HEAT_MODELS", "register_heat_model", "unregister_heat_model", "FRICTION_LAWS",
    "register_friction_law", "unregister_friction_law", "Model", "MODEL_PRESETS",
    "SCENARIO_PRESETS", "model_preset", "scenario_preset", "SimulationResult", "Scenario",
    "pulse_train", "SimulationError", "simulate", "FieldError",
]
