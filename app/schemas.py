"""Pydantic v2 schemas of the REST API, mirroring the pneucore dataclasses.

Units are SI and pressures absolute; every field says its unit. Pydantic
checks types and shapes; pneucore then checks the physics (a rod wider than
the bore, a command outside the valve's range, ...) and the API turns its
``FieldError`` into the same 422 format with the field path.
"""
from __future__ import annotations

import copy
from typing import Any, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field
from pydantic.fields import FieldInfo

from pneucore.heat import HEAT_PARAMETERS
from pneucore.model import VALVE_KINDS, FrictionSet, Gas, Jack, Model, Valve
from pneucore.scenario import COMMAND_INTERPOLATIONS, Initial, Scenario, Solver
from pneucore.study_def import DISTRIBUTIONS

Number = float


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


def from_lib(obj, name, description, **kw):
    """A pydantic ``Field`` whose default is ``obj.name``, read from the pneucore object.

    The pneucore dataclasses are the one source of every default; the schemas
    read them here, and tests/test_one_source.py checks every mirrored field
    (default and unit). A mutable default (a list) is copied for each request.
    """
    value = getattr(obj, name)
    if isinstance(value, (list, dict)):
        return Field(default_factory=lambda: copy.deepcopy(value), description=description, **kw)
    return Field(value, description=description, **kw)


_JACK, _VALVE, _FRICTION_SET, _GAS, _MODEL = Jack(), Valve(), FrictionSet(), Gas(), Model()
_SCENARIO, _SOLVER = Scenario(), Solver()
#: the choices of the pneucore registries, as pydantic literals
_VALVE_KIND = Literal[tuple(VALVE_KINDS)]
_INTERPOLATION = Literal[tuple(COMMAND_INTERPOLATIONS)]
_DISTRIBUTION_FIELDS = "; ".join(f"{name}: {', '.join(d.required + d.optional)}"
                                 for name, d in DISTRIBUTIONS.items())


# ---------------------------------------------------------------------------- model
class JackIn(_Strict):
    bore: Number = from_lib(_JACK, "bore", "Bore (piston) diameter [m]")
    rod_a: Number = from_lib(_JACK, "rod_a", "Rod diameter on the chamber-A side, 0 = no rod [m]")
    rod_b: Number = from_lib(_JACK, "rod_b", "Rod diameter on the chamber-B side, 0 = no rod [m]")
    stroke: Number = from_lib(_JACK, "stroke", "Stroke [m]")
    dead_volume_a: Number = from_lib(_JACK, "dead_volume_a", "Volume of chamber A at x = 0 [m^3]")
    dead_volume_b: Number = from_lib(_JACK, "dead_volume_b", "Volume of chamber B at x = stroke [m^3]")
    moving_mass: Number = from_lib(_JACK, "moving_mass", "Moving mass: piston, rod and load [kg]")
    load_force: Number = from_lib(_JACK, "load_force", "Constant external force pushing towards x = 0 [N]")
    wall_area_a: Optional[Number] = from_lib(_JACK, "wall_area_a", "Heat-exchange area of chamber A; null = follows the piston [m^2]")
    wall_area_b: Optional[Number] = from_lib(_JACK, "wall_area_b", "Heat-exchange area of chamber B; null = follows the piston [m^2]")


class PortTableIn(_Strict):
    opening: list[Number] = Field(..., description="Strictly increasing spool openings, at least two (one point would never close the valve) [-]")
    C: list[Number] = Field(..., description="Sonic conductance at each opening [m^3/(s Pa)]")
    b: list[Number] = Field(..., description="Critical pressure ratio at each opening, in [0, 1) [-]")
    m: Optional[list[Number]] = Field(None, description="Subsonic index at each opening [-]; null = 0.5 (paper Eq. 4)")


class ValveIn(_Strict):
    kind: _VALVE_KIND = from_lib(_VALVE, "kind", "Valve kind: 4/2 (edges P-A, A-R, P-B, B-R; opening -1..1) or 3/2 (P-A, A-R; opening 0..1) [-]")
    ports: dict[str, PortTableIn] = Field(..., description="Metering edge tables by edge name")
    b_chamber_pressure: Optional[Number] = Field(None, description="3/2 mode: absolute pressure held in chamber B; null = half the supply [Pa]")
    flow_law: str = from_lib(_VALVE, "flow_law", "Flow law name: iso6358 (Eq. 4-5) or saint_venant (Eq. 1-3) [-]")
    laminar_ratio: Number = from_lib(_VALVE, "laminar_ratio", "Pressure ratio above which edge flows are linearised [-]")


class SourceIn(_Strict):
    pressure: Number = Field(..., description="Absolute pressure [Pa]")
    temperature: Number = from_lib(_MODEL.ambient, "temperature", "Temperature [K]")


class HeatIn(_Strict):
    model: str = from_lib(_MODEL.heat, "model", "Heat model by name (GET /api/heat-models): isothermal, adiabatic, convective (Eq. 9), natural_convection, natural_and_jet [-]")
    coefficient: Number = from_lib(_MODEL.heat, "coefficient", "Convection coefficient h of Eq. 9 [W/(m^2 K)]")


# the other heat-model parameters, from their registry (unit, description): null = the default
for _name, _p in HEAT_PARAMETERS.items():
    if _name not in HeatIn.model_fields:
        HeatIn.model_fields[_name] = FieldInfo.from_annotated_attribute(
            Optional[Number], Field(None, description=f"{_p.description} [{_p.unit}]"))
HeatIn.model_rebuild(force=True)


class FrictionSetIn(_Strict):
    fc0: Number = from_lib(_FRICTION_SET, "fc0", "Constant Coulomb force [N]")
    fc_a: Number = from_lib(_FRICTION_SET, "fc_a", "Coulomb force per gauge pressure in A (Eq. 20) [N/Pa]")
    fc_b: Number = from_lib(_FRICTION_SET, "fc_b", "Coulomb force per gauge pressure in B (Eq. 20) [N/Pa]")
    kv0: Number = from_lib(_FRICTION_SET, "kv0", "Constant viscous coefficient [N s/m]")
    kv_a: Number = from_lib(_FRICTION_SET, "kv_a", "Viscous coefficient per gauge pressure in A (Eq. 19) [N s/(m Pa)]")
    kv_b: Number = from_lib(_FRICTION_SET, "kv_b", "Viscous coefficient per gauge pressure in B (Eq. 19) [N s/(m Pa)]")


class FrictionIn(_Strict):
    extend: FrictionSetIn = Field(default_factory=FrictionSetIn, description="Coefficients while extending (v > 0)")
    retract: Optional[FrictionSetIn] = Field(None, description="Coefficients while retracting (v < 0); null = same as extend")
    law: str = from_lib(_MODEL.friction, "law", "Friction law name [-]")


class GasIn(_Strict):
    r: Number = from_lib(_GAS, "r", "Specific gas constant [J/(kg K)]")
    gamma: Number = from_lib(_GAS, "gamma", "Ratio of specific heats [-]")


class ModelIn(_Strict):
    """An actuator model (see the pneucore README for the physics)."""
    jack: JackIn = Field(..., description="Cylinder geometry and load")
    valve: ValveIn = Field(..., description="Directional valve")
    supply: SourceIn = Field(default_factory=lambda: SourceIn(**_MODEL.supply.to_dict()), description="Supply node (absolute pressure [Pa], temperature [K])")
    ambient: SourceIn = Field(default_factory=lambda: SourceIn(**_MODEL.ambient.to_dict()), description="Ambient/exhaust node (absolute pressure [Pa], temperature [K])")
    heat: HeatIn = Field(default_factory=HeatIn, description="Heat exchange model")
    friction: FrictionIn = Field(default_factory=FrictionIn, description="Piston friction (Eq. 18-20)")
    effects: dict[str, dict[str, Number]] = Field(default_factory=dict, description="Catalog effects by name with their parameters (units in GET /api/effects)")
    gas: GasIn = Field(default_factory=GasIn, description="Ideal gas constants")
    name: str = Field("", description="Label")
    description: str = Field("", description="Free text")
    notes: str = Field("", description="Free text")


# ---------------------------------------------------------------------------- scenario
class InitialIn(_Strict):
    p_a: Optional[Number] = Field(None, description="Initial absolute pressure in A; null = ambient [Pa]")
    p_b: Optional[Number] = Field(None, description="Initial absolute pressure in B; null = ambient [Pa]")
    T_a: Optional[Number] = Field(None, description="Initial gas temperature in A; null = ambient [K]")
    T_b: Optional[Number] = Field(None, description="Initial gas temperature in B; null = ambient [K]")


class SolverIn(_Strict):
    rtol: Number = from_lib(_SOLVER, "rtol", "Relative tolerance of the error control [-]")
    max_step: Number = from_lib(_SOLVER, "max_step", "Largest integration step [s]")
    max_steps: int = from_lib(_SOLVER, "max_steps", "Step budget; the run stops with an error beyond it [-]")
    max_events: int = from_lib(_SOLVER, "max_events", "Event budget (stick/slip/stop/command) [-]")


class ScenarioIn(_Strict):
    duration: Optional[Number] = from_lib(_SCENARIO, "duration", "Simulated time [s]")
    sample_period: Optional[Number] = from_lib(_SCENARIO, "sample_period", "Output sample period [s]")
    command: Optional[list[tuple[Number, Number]]] = from_lib(_SCENARIO, "command", "Valve command breakpoints [[t [s], u [-]], ...]",
                                                       validate_default=True)  # pairs, as a request's
    command_interpolation: _INTERPOLATION = from_lib(_SCENARIO, "command_interpolation", "Zero-order hold or linear between breakpoints [-]")
    locked: bool = from_lib(_SCENARIO, "locked", "Piston locked at x0 (chamber test) [-]")
    x0: Optional[Number] = from_lib(_SCENARIO, "x0", "Initial position from the A end [m]")
    initial: InitialIn = Field(default_factory=InitialIn, description="Initial chamber state")
    solver: Optional[SolverIn] = Field(None, description="Integrator settings")
    name: str = Field("", description="Label")
    description: str = Field("", description="Free text")

    def plain(self):
        d = self.model_dump(exclude_none=True)
        d["initial"] = self.initial.model_dump()
        return d


# ---------------------------------------------------------------------------- requests
class SimulateRequest(_Strict):
    model: ModelIn = Field(..., description="Actuator model")
    scenario: ScenarioIn = Field(..., description="Scenario")
    series: Optional[list[str]] = Field(None, description="Series to return (default: all) [-]")


class HeatModelsRequest(SimulateRequest):
    heat_models: list[str] = Field(["isothermal", "adiabatic", "convective"], description="Heat models to run [-]")


class HeatModelsSimulateRequest(SimulateRequest):
    heat_models: Optional[list[str]] = Field(None, description="Heat models to run (default: every model of GET /api/heat-models) [-]")


class MeasurementIn(BaseModel):
    model_config = ConfigDict(extra="allow")
    t: list[Optional[Number]] = Field(..., description="Sample times [s]")
    u: list[Optional[Number]] = Field(..., description="Valve command [-]")
    name: Optional[str] = Field(None, description="Label")


class ExperimentIn(_Strict):
    name: Optional[str] = Field(None, description="Label")
    scenario: Optional[dict[str, Any]] = Field(None, description="Scenario context (locked, x0, ...); command and duration default to the measurement's")
    measurement: Optional[MeasurementIn] = Field(None, description="Inline measurement: t [s], u [-], p_a/p_b [Pa abs], x [m], v [m/s], T_a/T_b [K]; null marks a missing sample")
    dataset_id: Optional[str] = Field(None, description="Stored dataset to use instead of an inline measurement")
    load_force: Optional[Number] = Field(None, description="Load during this experiment [N]")
    supply_pressure: Optional[Number] = Field(None, description="Supply pressure during this experiment [Pa abs]")


class CompareRequest(_Strict):
    model: ModelIn = Field(..., description="Actuator model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments")
    heat_models: Union[bool, list[str], None] = Field(None, description="Also compare under these heat models (true = all three) [-]")
    residuals: bool = Field(True, description="Return the residual series [-]")


class ParamBounds(_Strict):
    min: Optional[Number] = Field(None, description="Lower bound (unit of the parameter)")
    max: Optional[Number] = Field(None, description="Upper bound (unit of the parameter)")
    value: Optional[Number] = Field(None, description="Starting value (unit of the parameter)")
    vary: bool = Field(True, description="Fit it [-]")


class CalibrateRequest(_Strict):
    model: ModelIn = Field(..., description="Starting model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments fitted jointly")
    parameters: dict[str, ParamBounds] = Field(..., description="Parameter paths (e.g. heat.coefficient, friction.extend.fc0, effects.piston_leakage.conductance, valve.ports.P-A.C as a scale) with bounds")
    max_nfev: int = Field(40, description="Budget of residual evaluations [-]")


class DiagnoseRequest(_Strict):
    model: ModelIn = Field(..., description="Current model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments")
    candidates: Optional[list[str]] = Field(None, description="Effects to consider; null = all applicable [-]")
    uncertain: list[str] = Field(default_factory=list, description="Base parameter paths refitted along [-]")


class DatasetJsonIn(_Strict):
    name: Optional[str] = Field(None, description="Label")
    description: str = Field("", description="Free text")
    scenario: dict[str, Any] = Field(default_factory=dict, description="Context: locked [-], x0 [m], ...")
    measurement: MeasurementIn = Field(..., description="Measurement (SI units; null = missing)")


class SessionCreate(_Strict):
    name: str = Field("session", description="Label")
    model: ModelIn = Field(..., description="Starting model (version 0)")
    experiments: list[ExperimentIn] = Field(default_factory=list, description="Experiments the errors are computed on")


class VersionCreate(_Strict):
    model: ModelIn = Field(..., description="New model version")
    added: Optional[str] = Field(None, description="Effect added at this step [-]")
    params: dict[str, Any] = Field(default_factory=dict, description="Fitted parameters of the added effect")
    note: str = Field("", description="Free text")


class StudyRequest(_Strict):
    model: ModelIn = Field(..., description="Actuator model")
    scenario: ScenarioIn = Field(..., description="Scenario run for every parameter set")
    parameters: dict[str, dict[str, Any]] = Field(..., description=f"Parameter path -> {{grid: [...]}} or {{distribution: NAME, fields}} with the fields of each distribution ({_DISTRIBUTION_FIELDS}), in the unit of the parameter")
    samples: Optional[int] = Field(None, description="Number of random samples (distributions) [-]")
    seed: int = Field(0, description="Random seed [-]")
    metrics: Optional[list[str]] = Field(None, description="Metrics to compute; null = all (see pneucore.study METRICS) [-]")
    scheduler: Optional[str] = Field(None, max_length=64, description="Where to run, by name (never an address): 'local' = this machine's process pool, 'dask' = the Dask cluster configured on the server ($PNEUCORE_DASK_SCHEDULER or --scheduler; see GET /api/studies/clusters); null = 'dask' when configured, else 'local' [-]")
    workers: Optional[int] = Field(None, description="Local pool size, at most max_workers of GET /api/limits (the CPUs available); 0 = in the service's process; null = one per CPU [-]")
    name: str = Field("", description="Label of the study")


# ---------------------------------------------------------------------------- responses
class SimulateResponse(BaseModel):
    series: dict[str, list[Any]] = Field(..., description="Sampled series by name (SI units, see units)")
    units: dict[str, str] = Field(..., description="Unit of each series")
    events: list[dict[str, Any]] = Field(..., description="Events: t [s], kind (command/slip/stick/stop/reverse), mode")
    stats: dict[str, Any] = Field(..., description="Solver statistics")
    status: int = Field(..., description="0 = ok")
    message: str = Field(..., description="Solver status message")


class JobResponse(BaseModel):
    id: str = Field(..., description="Job id")
    kind: str = Field(..., description="Job kind")
    status: str = Field(..., description="queued, running, done, error, or interrupted (the server stopped while it was queued or running; submit it again)")
    progress: float = Field(..., description="Fraction done [-]")
    step: str = Field(..., description="Current step")
    error: Optional[str] = Field(None, description="Error message when status is error")
    result: Optional[Any] = Field(None, description="Result when done")


class HeatModelsCompareRequest(_Strict):
    model: ModelIn = Field(..., description="Model; its heat section is each calibration's start")
    experiments: list[ExperimentIn] = Field(..., description="Experiments fitted jointly")
    heat_models: Optional[list[str]] = Field(None, description="Heat models to compare (default: all) [-]")
    sensor: bool = Field(False, description="Also fit the gas-temperature sensor's time constant heat.sensor_time_constant [s] for each model [-]")
    max_nfev: int = Field(60, description="Residual evaluations per calibration (at most 200) [-]")
