"""Request and answer bodies of the control endpoints (issue 42): POST /api/linearize, and the
``controller`` a scenario of POST /api/simulate may carry instead of ``command``."""
from __future__ import annotations

from typing import Any, Optional

from pydantic import BaseModel, ConfigDict, Field

from .schemas import ModelIn, Number


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class OperatingPointIn(_Strict):
    x: Optional[Number] = Field(None, description="Position [m]; null = mid-stroke")
    p_a: Optional[Number] = Field(None, description="Chamber A pressure [Pa abs]; null = the equilibrium (force balance, mean pressure (p_supply + p_atm) / 2)")
    p_b: Optional[Number] = Field(None, description="Chamber B pressure [Pa abs]; null = the equilibrium")
    u: Number = Field(0.0, description="Valve command at the operating point [-] (a valve with overlap has no flow gain inside it)")


class LinearizeRequest(_Strict):
    model: ModelIn = Field(..., description="Actuator model")
    operating_point: OperatingPointIn = Field(default_factory=OperatingPointIn, description="Operating point; a field left out: the equilibrium at mid-stroke")
    frequencies: Optional[list[Number]] = Field(None, max_length=2000, description="Frequencies of the response position/command [Hz]; null = 60 points from 0.1 to 1000 Hz")


class LinearizeResponse(BaseModel):
    natural_frequency: float = Field(..., description="Natural frequency of the piston's mode [Hz]")
    damping: Optional[float] = Field(..., description="Damping ratio of that mode [-]")
    poles: list[list[float]] = Field(..., description="Eigenvalues of A as [re, im] [1/s]")
    A: list[list[float]] = Field(..., description="State matrix [state unit / (s state unit)]")
    B: list[list[float]] = Field(..., description="Input matrix (input: the valve command u [-]) [state unit / s]")
    C: list[list[float]] = Field(..., description="Output matrix (output: the position x [m])")
    D: list[list[float]] = Field(..., description="Feedthrough [m]")
    states: list[str] = Field(..., description="State names, in the order of A's rows")
    state_units: list[str] = Field(..., description="Unit of each state")
    operating_point: dict[str, float] = Field(..., description="x [m], p_a, p_b [Pa abs], u [-]")
    frequency_response: dict[str, list[float]] = Field(..., description="f [Hz], magnitude [m] (x/u), phase [deg]")
    closed_form: dict[str, float] = Field(..., description="Natural frequency of the closed-chamber spring sqrt(k A^2 (p_a/V_a + p_b/V_b) / m), isothermal (k = 1) and adiabatic (k = gamma) [Hz]")


class ControllerIn(_Strict):
    kind: str = Field(..., max_length=64, description="Controller by name: pid, sliding_mode, onoff, pva, force_pid, or one registered from Python (GET /api/controllers)")
    gains: dict[str, Any] = Field(default_factory=dict, description="Gains by name, SI (kp [1/m]: valve opening per metre of error; see GET /api/controllers for each kind's gains and units)")
    setpoint: Any = Field(..., description="Reference position: [[t [s], x [m]], ...] held between points, or a shape {kind: step|multi_step|ramp|sine|jerk_limited|recorded, ...} [m, s]")
    sample_period: Number = Field(1e-3, description="Controller sample period (zero-order hold) [s]")
    settle_band: Optional[Number] = Field(None, description="Settling band of the metrics [m]; null = 2 % of the last move")
    seed: int = Field(0, description="Seed of the sensors' noise (model.effects.sensor_lag: position_noise [m], pressure_noise [Pa]): the same seed, the same noise [-]")
    rate_filter: Number = Field(2e-3, description="Time constant of the filtered differentiator that estimates, from the sensed position, the velocity and acceleration the laws read (v_k = a v_(k-1) + (1 - a)(x_k - x_(k-1))/T_s, a = tau/(tau + T_s), and the same on v for the acceleration); 0 = the plain backward difference [s]")
    ideal_rates: bool = Field(False, description="The laws read the piston's true velocity and acceleration instead of the estimates (a simulation's idealisation, no rig has it) [-]")


class ControllerInfo(BaseModel):
    kind: str = Field(..., description="Name, for scenario.controller.kind")
    description: str = Field(..., description="The law, in words")
    gains: dict[str, Any] = Field(..., description="Each gain's unit, default (null: required) and description")
    valves: list[str] = Field(..., description="Valve kinds it can drive")


class ControllersResponse(BaseModel):
    controllers: list[ControllerInfo] = Field(..., description="The registered controller kinds")


_SPEC = "Specification {metric: largest |value|} in the metric's unit: rise_time, settling_time [s], overshoot [-], steady_state_error, rms_error, hunting_amplitude [m], hunting_frequency [Hz], switchings [-], air_per_move [NL]; a run meets it when stable and every listed metric is defined and within its bound; null = none"


class ControlStudyRequest(_Strict):
    study: dict[str, Any] = Field(..., description="A robustness study (model, scenario with a controller, parameters by path with grids or distributions, samples, seed); see docs/guides/position-control.md")
    specification: Optional[dict[str, Any]] = Field(None, description=_SPEC + " (the answer adds meets per run and summary.meets_fraction)")


class TuneRequest(_Strict):
    study: dict[str, Any] = Field(..., description="The ensemble: a closed-loop study (its controller's gains are the base)")
    gains: dict[str, list[Number]] = Field(..., description="Gain values to try, full factorial, SI units of the controller's gains")
    objective: str = Field("rms_error", max_length=64, description="Metric whose worst |value| over the ensemble is minimised: rise_time, settling_time [s], overshoot [-], steady_state_error, rms_error, hunting_amplitude [m], ...")
    specification: Optional[dict[str, Any]] = Field(None, description=_SPEC + " (the sets meeting it on the most runs rank first, then the worst objective)")
