"""pneucore: physics and numerics of valve-driven pneumatic actuators.

The model is Maré, Geider & Colin, "An improved dynamic model of pneumatic
actuators": ISO 6358 valve edges, chambers from mass and energy
conservation with convective exchange, Coulomb + viscous friction depending
on pressure and quadrant with exact stick/slip. No web framework here.
"""
from . import _cache

_cache.check()      # numba's cache must not outlive an edit of any core module

from .effects import EFFECTS, Effect, Parameter, register_effect, unregister_effect
from .flow import FLOW_LAWS, iso6358_mass_flow, saint_venant_mass_flow
from .heat import HEAT_MODELS
from .model import Model
from .presets import MODEL_PRESETS, SCENARIO_PRESETS, model_preset, scenario_preset
from .result import SimulationResult
from .scenario import Scenario, pulse_train
from .simulate import SimulationError, simulate
from .validation import FieldError

__version__ = "0.1.0"

__all__ = [
    "EFFECTS", "Effect", "Parameter", "register_effect", "unregister_effect", "FLOW_LAWS",
    "iso6358_mass_flow", "saint_venant_mass_flow", "HEAT_MODELS", "Model", "MODEL_PRESETS",
    "SCENARIO_PRESETS", "model_preset", "scenario_preset", "SimulationResult", "Scenario",
    "pulse_train", "SimulationError", "simulate", "FieldError",
]
