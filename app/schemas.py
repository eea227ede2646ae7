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

from pneucore.analysis.phase_excess import START_SAMPLES
from pneucore.physics.heat import HEAT_MODELS, HEAT_PARAMETERS
from pneucore.description.docstrings import api_description
from pneucore.description.model import (B_CHAMBER_MODES, VALVE_KINDS, Friction, FrictionSet, Gas, Heat, Jack, Model,
                                 PortTable, Source, Valve)
from pneucore.description.scenario import COMMAND_INTERPOLATIONS, STARTS, Initial, Scenario, Solver
from pneucore.study.definition import DISTRIBUTIONS

Number = float

from typing import Annotated as _Annotated  # noqa: E402

from pydantic import StringConstraints  # noqa: E402

from .config import Limits as _Limits  # noqa: E402

#: Text with no control character (the pattern of names and descriptions; a refusal says so in
#: words, app.main's validation_error)
NO_CONTROL = r"^[^\x00-\x1f\x7f]*$"
#: A name: at most Limits.max_name_length characters, no control character (a tab, a line break,
#: an escape sequence would reach logs, file names and CSV cells)
Name = _Annotated[str, StringConstraints(max_length=_Limits.max_name_length, pattern=NO_CONTROL)]
#: Free text (a description): at most Limits.max_text_length characters, and no control
#: character either: a CR, LF or NUL in a description would reach the same logs, reports and
#: CSV headers as a name's
Text = _Annotated[str, StringConstraints(max_length=_Limits.max_text_length, pattern=NO_CONTROL)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


def described(cls, name):
    """The description of the pneucore field ``cls.name``, from its numpydoc docstring."""
    return api_description(cls, name)


def from_lib(obj, name, description=None, **kw):
    """A pydantic ``Field`` whose default is ``obj.name`` and whose description is the
    field's, both read from the pneucore object.

    The pneucore dataclasses are the one source of every default and every
    description (their docstrings); the schemas read them here, and
    tests/test_one_source.py checks every mirrored field (default, description,
    unit). A mutable default (a list) is copied for each request.
    """
    if description is None:
        description = described(type(obj), name)
    value = getattr(obj, name)
    if isinstance(value, (list, dict)):
        return Field(default_factory=lambda: copy.deepcopy(value), description=description, **kw)
    return Field(value, description=description, **kw)


_JACK, _VALVE, _FRICTION_SET, _GAS, _MODEL = Jack(), Valve(), FrictionSet(), Gas(), Model()
_SCENARIO, _SOLVER = Scenario(), Solver()
#: the choices of the pneucore registries, as pydantic literals
_VALVE_KIND = Literal[tuple(VALVE_KINDS)]
_B_CHAMBER = Literal[tuple(B_CHAMBER_MODES)]
_INTERPOLATION = Literal[tuple(COMMAND_INTERPOLATIONS)]
_START = Literal[tuple(STARTS)]
_DISTRIBUTION_FIELDS = "; ".join(f"{name}: {', '.join(d.required + d.optional)}"
                                 for name, d in DISTRIBUTIONS.items())


# ---------------------------------------------------------------------------- model
class JackIn(_Strict):
    bore: Number = from_lib(_JACK, "bore")
    rod_a: Number = from_lib(_JACK, "rod_a")
    rod_b: Number = from_lib(_JACK, "rod_b")
    stroke: Number = from_lib(_JACK, "stroke")
    dead_volume_a: Number = from_lib(_JACK, "dead_volume_a")
    dead_volume_b: Number = from_lib(_JACK, "dead_volume_b")
    moving_mass: Number = from_lib(_JACK, "moving_mass")
    load_force: Number = from_lib(_JACK, "load_force")
    wall_area_a: Optional[Number] = from_lib(_JACK, "wall_area_a")
    wall_area_b: Optional[Number] = from_lib(_JACK, "wall_area_b")
    mounting_angle: Number = from_lib(_JACK, "mounting_angle")


class PortTableIn(_Strict):
    opening: list[Number] = Field(..., description=described(PortTable, "opening"))
    C: list[Number] = Field(..., description=described(PortTable, "C"))
    b: list[Number] = Field(..., description=described(PortTable, "b"))
    m: Optional[list[Number]] = Field(None, description=described(PortTable, "m"))


class ValveIn(_Strict):
    kind: _VALVE_KIND = from_lib(_VALVE, "kind")
    ports: dict[str, PortTableIn] = Field(..., description=described(Valve, "ports"))
    b_chamber_pressure: Optional[Number] = Field(None, description=described(Valve, "b_chamber_pressure"))
    flow_law: str = from_lib(_VALVE, "flow_law")
    laminar_ratio: Number = from_lib(_VALVE, "laminar_ratio")
    b_chamber: _B_CHAMBER = from_lib(_VALVE, "b_chamber")
    b_chamber_conductance: Number = from_lib(_VALVE, "b_chamber_conductance")
    b_chamber_critical_ratio: Number = from_lib(_VALVE, "b_chamber_critical_ratio")
    on_time: Number = from_lib(_VALVE, "on_time")
    off_time: Number = from_lib(_VALVE, "off_time")
    rest_opening: Optional[Number] = from_lib(_VALVE, "rest_opening")


class SourceIn(_Strict):
    pressure: Number = Field(..., description=described(Source, "pressure"))
    temperature: Number = from_lib(_MODEL.ambient, "temperature")


class HeatIn(_Strict):
    model: str = from_lib(_MODEL.heat, "model")
    coefficient: Number = from_lib(_MODEL.heat, "coefficient")


# the other heat-model parameters, from their registry (unit, description): null = the default
for _name, _p in HEAT_PARAMETERS.items():
    if _name not in HeatIn.model_fields:
        HeatIn.model_fields[_name] = FieldInfo.from_annotated_attribute(
            Optional[Number], Field(None, description=f"{_p.description} [{_p.unit}]"))
HeatIn.model_rebuild(force=True)


class FrictionSetIn(_Strict):
    fc0: Number = from_lib(_FRICTION_SET, "fc0")
    fc_a: Number = from_lib(_FRICTION_SET, "fc_a")
    fc_b: Number = from_lib(_FRICTION_SET, "fc_b")
    kv0: Number = from_lib(_FRICTION_SET, "kv0")
    kv_a: Number = from_lib(_FRICTION_SET, "kv_a")
    kv_b: Number = from_lib(_FRICTION_SET, "kv_b")


class FrictionIn(_Strict):
    extend: FrictionSetIn = Field(default_factory=FrictionSetIn, description=described(Friction, "extend"))
    retract: Optional[FrictionSetIn] = Field(None, description=described(Friction, "retract"))
    law: str = from_lib(_MODEL.friction, "law")


class GasIn(_Strict):
    r: Number = from_lib(_GAS, "r")
    gamma: Number = from_lib(_GAS, "gamma")


class ModelIn(_Strict):
    """An actuator model (see the pneucore README for the physics)."""
    jack: JackIn = Field(..., description=described(Model, "jack"))
    valve: ValveIn = Field(..., description=described(Model, "valve"))
    supply: SourceIn = Field(default_factory=lambda: SourceIn(**_MODEL.supply.to_dict()), description=described(Model, "supply"))
    ambient: SourceIn = Field(default_factory=lambda: SourceIn(**_MODEL.ambient.to_dict()), description=described(Model, "ambient"))
    heat: HeatIn = Field(default_factory=HeatIn, description=described(Model, "heat"))
    friction: FrictionIn = Field(default_factory=FrictionIn, description=described(Model, "friction"))
    effects: dict[str, dict[str, Number]] = Field(default_factory=dict, description=described(Model, "effects"))
    gas: GasIn = Field(default_factory=GasIn, description=described(Model, "gas"))
    name: Name = Field("", description=described(Model, "name"))
    description: Text = Field("", description=described(Model, "description"))
    notes: str = Field("", description=described(Model, "notes"))
    provenance: dict[str, dict[str, Any]] = Field(default_factory=dict, description=described(Model, "provenance"))


# ---------------------------------------------------------------------------- scenario
class InitialIn(_Strict):
    p_a: Optional[Number] = Field(None, description=described(Initial, "p_a"))
    p_b: Optional[Number] = Field(None, description=described(Initial, "p_b"))
    T_a: Optional[Number] = Field(None, description=described(Initial, "T_a"))
    T_b: Optional[Number] = Field(None, description=described(Initial, "T_b"))


class SolverIn(_Strict):
    rtol: Number = from_lib(_SOLVER, "rtol")
    max_step: Number = from_lib(_SOLVER, "max_step")
    max_steps: int = from_lib(_SOLVER, "max_steps")
    max_events: int = from_lib(_SOLVER, "max_events")


class ScenarioIn(_Strict):
    duration: Optional[Number] = from_lib(_SCENARIO, "duration")
    sample_period: Optional[Number] = from_lib(_SCENARIO, "sample_period")
    command: Optional[list[tuple[Number, Number]]] = from_lib(_SCENARIO, "command",
                                                       validate_default=True)  # pairs, as a request's
    command_interpolation: _INTERPOLATION = from_lib(_SCENARIO, "command_interpolation")
    locked: bool = from_lib(_SCENARIO, "locked")
    x0: Optional[Number] = from_lib(_SCENARIO, "x0")
    initial: InitialIn = Field(default_factory=InitialIn, description=described(Scenario, "initial"))
    start: _START = from_lib(_SCENARIO, "start")
    solver: Optional[SolverIn] = Field(None, description=described(Scenario, "solver"))
    name: Name = Field("", description=described(Scenario, "name"))
    description: Text = Field("", description=described(Scenario, "description"))
    controller: Optional[dict[str, Any]] = Field(None, description="Closed loop instead of command (issue 42): {kind: pid|sliding_mode|onoff|pva|force_pid, gains: {...} (SI; kp [1/m]: valve opening per metre of error), setpoint: [[t [s], x [m]], ...] or a shape, sample_period [s] (default 0.001), settle_band [m], seed [-] (of the sensors' noise, default 0), rate_filter [s] (time constant of the velocity and acceleration estimator, default 0.002), ideal_rates [-] (true: the laws read the piston's true velocity and acceleration, default false)}; the controller reads the position and pressures through the model's sensors (model.effects.sensor_lag: position_resolution [m], position_time_constant [s], position_noise [m], time_constant [s], pressure_noise [Pa], pressure_resolution [Pa]) and the velocity and acceleration estimated from the sensed position; the answer adds series.x_ref [m], what the controller read (series.v_est [m/s], series.a_est [m/s^2]; series.x_sensed [m] where the model has a position sensor; series.p_a_sensed, p_b_sensed [Pa] where its transducers have noise or a resolution) and stats.control (docs/guides/position-control.md)")

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
    u: Optional[list[Optional[Number]]] = Field(None, description="Valve command [-]; a record without it needs the experiment's scenario.command (POST /api/datasets/{id}/propose-command proposes one)")
    name: Optional[Name] = Field(None, description="Label")


class ExperimentIn(_Strict):
    name: Optional[Name] = Field(None, description="Label")
    scenario: Optional[dict[str, Any]] = Field(None, description="Scenario context (locked, x0, ...); command ([[t [s], u [-]], ...], held) and duration [s] default to the measurement's; a record without a u column needs the command here")
    measurement: Optional[MeasurementIn] = Field(None, description="Inline measurement: t [s], u [-], p_a/p_b [Pa abs], x [m], v [m/s], T_a/T_b [K], F rod force on the load, positive outward [N], q_a/q_b mass flow into A/B and q_s from the supply [kg/s], p_s supply pressure [Pa abs]; null marks a missing sample; meta.accuracy {signal or 'signal[unit]': sensor accuracy, the standard deviation of its error in that unit (a difference: bar(g) and degC as bar and K)}: the fit weighs that signal by it instead of the noise estimated from the record")
    dataset_id: Optional[str] = Field(None, description="Stored dataset to use instead of an inline measurement")
    load_force: Optional[Number] = Field(None, description="Load during this experiment [N]")
    supply_pressure: Optional[Number] = Field(None, description="Supply pressure during this experiment [Pa abs]")
    time_offset: Optional[Number] = Field(None, description="Measurement time at which the model starts (model t = measurement t - offset); null = the measurement's own t = 0, where an initial state given in the scenario applies; at most the first sample's time [s]")


#: What a request's ``known`` list means (one text for calibrate, diagnose and refine)
KNOWN_DOC = ("Parameter paths whose values are known (a weighed mass jack.moving_mass, the bore, a load "
             "from gravity jack.load_force): never moved by any fit; a fit that would need one far off "
             "says so as a finding [-]")
#: What a request's ``bench_known`` flag means (one text for calibrate, diagnose and refine)
BENCH_KNOWN_DOC = ("true (default): the values the model's provenance says were identified on a bench "
                   "(source bench) are known: held at the bench's value even when listed to be fitted "
                   "(in parameters or uncertain; the answer's bench_held names them), and a fit that "
                   "would need one far off says so (known_disagree); false: fitted like any other [-]")


class CompareRequest(_Strict):
    model: ModelIn = Field(..., description="Actuator model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments")
    heat_models: Union[bool, list[str], None] = Field(None, description="Also compare under these heat models (true = all three); their errors are in the JSON answer, the CSV answer carries the model's own series [-]")
    residuals: bool = Field(True, description="Return the residual series [-]")


class ParamBounds(_Strict):
    min: Optional[Number] = Field(None, description="Lower bound (unit of the parameter)")
    max: Optional[Number] = Field(None, description="Upper bound (unit of the parameter)")
    value: Optional[Number] = Field(None, description="Starting value (unit of the parameter)")
    vary: bool = Field(True, description="Fit it [-]")


class CalibrateRequest(_Strict):
    model: ModelIn = Field(..., description="Starting model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments fitted jointly")
    parameters: dict[str, ParamBounds] = Field(..., description="Parameter paths (e.g. heat.coefficient, friction.extend.fc0, effects.piston_leakage.conductance, valve.ports.P-A.C as a scale) with bounds; sensors.<signal>.offset (the signal's SI unit: Pa, m, K) and sensors.<signal>.gain [-] fit a measured signal's sensor zero and gain error (a sensor finding, not physics)")
    max_nfev: int = Field(40, ge=1, le=_Limits.max_nfev,
                          description=f"Budget of residual evaluations (at most {_Limits.max_nfev}) [-]")
    known: list[str] = Field(default_factory=list, description=KNOWN_DOC)
    bench_known: bool = Field(True, description=BENCH_KNOWN_DOC)


#: A request's ``scheduler``: a cluster name (one source for the study and diagnosis requests)
CLUSTER_NAME_DOC = ("Where to run, by name (never an address): 'local' = this machine, 'dask' = the Dask "
                    "cluster configured on the server ($PNEUCORE_DASK_SCHEDULER or --scheduler; see GET "
                    "/api/studies/clusters); null = 'dask' when configured, else 'local'")


class DiagnoseRequest(_Strict):
    model: ModelIn = Field(..., description="Current model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments")
    candidates: Optional[list[str]] = Field(None, description="Effects to consider; null = all applicable [-]")
    uncertain: list[str] = Field(default_factory=list, description="Base parameter paths refitted along [-]")
    known: list[str] = Field(default_factory=list, description=KNOWN_DOC)
    bench_known: bool = Field(True, description=BENCH_KNOWN_DOC)
    scheduler: Optional[str] = Field(None, max_length=64, description=CLUSTER_NAME_DOC + ": where the candidates' joint refits run (one task each on the cluster) [-]")


def _refine_default(name):
    """A default of :func:`pneucore.analysis.history.refine` (one source for the API's)."""
    import inspect

    from pneucore.analysis.history import refine
    return inspect.signature(refine).parameters[name].default


class RefineRequest(_Strict):
    model: ModelIn = Field(..., description="Starting model")
    experiments: list[ExperimentIn] = Field(..., description="Experiments")
    uncertain: list[str] = Field(default_factory=list, description="Base parameter paths refitted along; given, they replace the automatic choice [-]")
    known: list[str] = Field(default_factory=list, description=KNOWN_DOC)
    bench_known: bool = Field(True, description=BENCH_KNOWN_DOC)
    max_rounds: int = Field(_refine_default("max_rounds"), ge=1, le=8, description="Most rounds (diagnose, apply the findings) [-]")
    scheduler: Optional[str] = Field(None, max_length=64, description=CLUSTER_NAME_DOC + ": where each round's candidate refits run (one task each on the cluster) [-]")


class DatasetJsonIn(_Strict):
    name: Optional[Name] = Field(None, description="Label")
    description: Text = Field("", description="Free text")
    scenario: dict[str, Any] = Field(default_factory=dict, description="Context: locked [-], x0 [m], ...")
    measurement: MeasurementIn = Field(..., description="Measurement (SI units; null = missing)")
    ambient_pressure: Optional[Number] = Field(None, description="The rig's ambient pressure for gauge columns such as \"p_a[bar(g)]\"; null = the model's default ambient [Pa]")


class SessionCreate(_Strict):
    name: Name = Field("session", description="Label")
    model: ModelIn = Field(..., description="Starting model (version 0)")
    experiments: list[ExperimentIn] = Field(default_factory=list, description="Experiments the errors are computed on")


class VersionCreate(_Strict):
    model: ModelIn = Field(..., description="New model version")
    added: Optional[str] = Field(None, description="Effect added at this step [-]")
    params: dict[str, Any] = Field(default_factory=dict, description="Fitted parameters of the added effect")
    note: str = Field("", description="Free text")
    experiments: Optional[list[ExperimentIn]] = Field(None, description="The session's experiments from this version on, when the user's data changed (the same session goes on; each version records the set its errors are on); null = the session's current set")


class StudyRequest(_Strict):
    model: ModelIn = Field(..., description="Actuator model")
    scenario: ScenarioIn = Field(..., description="Scenario run for every parameter set; one naming a controller (instead of a command) makes a closed-loop study: every run is that closed loop, its metrics the loop's (pneucore.control.metrics.CONTROL_METRICS: rise_time, settling_time [s], overshoot [-], steady_state_error [m], ...)")
    parameters: dict[str, dict[str, Any]] = Field(..., description=f"Parameter path -> {{grid: [...]}} or {{distribution: NAME, fields}} with the fields of each distribution ({_DISTRIBUTION_FIELDS}), in the unit of the parameter")
    samples: Optional[int] = Field(None, description="Number of random samples (distributions) [-]")
    seed: int = Field(0, description="Random seed [-]")
    metrics: Optional[list[str]] = Field(None, description="Metrics to compute; null = all (see pneucore.study METRICS) [-]")
    scheduler: Optional[str] = Field(None, max_length=64, description=CLUSTER_NAME_DOC + " (for a study, 'local' is this machine's process pool) [-]")
    workers: Optional[int] = Field(None, description="Local pool size, at most max_workers of GET /api/limits (the CPUs available); 0 = in the service's process; null = one per CPU [-]")
    name: Name = Field("", description="Label of the study")


# ---------------------------------------------------------------------------- responses
class SimulateResponse(BaseModel):
    series: dict[str, list[Any]] = Field(..., description="Sampled series by name (SI units, see units)")
    units: dict[str, str] = Field(..., description="Unit of each series")
    events: list[dict[str, Any]] = Field(..., description="Events: t [s], kind (command/slip/stick/stop/reverse), mode; a stop also v, the piston velocity at the impact [m/s]")
    stats: dict[str, Any] = Field(..., description="Solver statistics; `stroke` the stroke metrics; "
                                  "`warnings` (list of text, only when there are any) where a "
                                  "part of the model is not adequate for the command, e.g. a "
                                  "tube long against its changes (delay in ms)")
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
    max_nfev: int = Field(60, ge=1, le=_Limits.max_nfev,
                          description=f"Residual evaluations per calibration (at most {_Limits.max_nfev}) [-]")


# ---------------------------------------------------------------------------- file import
class ImportConversion(BaseModel):
    column: str = Field(..., description="Column as written in the file")
    signal: str = Field(..., description="Signal it was read as (t, u, p_a, p_b, x, v, T_a, T_b, F, q_a, q_b, q_s, p_s) [-]")
    from_: str = Field(..., alias="from", description="Unit in the file (canonical spelling: barg for bar(g))")
    to: str = Field(..., description="SI unit stored")
    ambient_pressure: Optional[Number] = Field(None, description="Ambient pressure added for a gauge unit [Pa]; null = absolute")
    how: str = Field(..., description="name, alias (Zeit, Time, p_A...) or mapping (the request's columns)")
    gain: Optional[Number] = Field(None, description="Sensor gain of a mapped sensor: unit 'from' per raw unit (1 bar/V) [from/raw]")
    offset: Optional[Number] = Field(None, description="Sensor offset added after the gain, in unit 'from' [from]")
    raw_unit: Optional[str] = Field(None, description="What the raw column holds (V, mA) [-]")


class MissingCells(BaseModel):
    column: str = Field(..., description="Column as written in the file")
    count: int = Field(..., description="Number of blank or missing-marker cells (NaN, NA, -...) [-]")
    rows: list[tuple[int, int]] = Field(..., description="Runs of data rows [first, last], 1-based after the header [-]")


class ImportReport(BaseModel):
    model_config = ConfigDict(extra="allow")
    format: str = Field(..., description="csv, tdms, mat or json")
    encoding: Optional[str] = Field(None, description="Detected text encoding (CSV)")
    delimiter: Optional[str] = Field(None, description="Detected delimiter (CSV)")
    decimal: Optional[str] = Field(None, description="Detected decimal mark (CSV): '.' or ','")
    units_row: Optional[bool] = Field(None, description="A units row was found under the header (CSV)")
    ambient_pressure: Number = Field(..., description="Ambient pressure used for gauge units [Pa]")
    conversions: list[ImportConversion] = Field(..., description="Every column read, with its unit conversion")
    ignored_columns: list[str] = Field(..., description="Columns not read (mapped to null, or simulator-only columns of an export)")
    missing_cells: list[MissingCells] = Field(..., description="Every blank or missing-marker cell, by column")
    warnings: list[str] = Field(..., description="Implausible values, e.g. an absolute pressure at rest far below ambient (gauge values?)")


class DatasetInfo(BaseModel):
    id: str = Field(..., description="Dataset id")
    name: str = Field(..., description="Label")
    created: float = Field(..., description="Creation time, Unix epoch [s]")
    n_samples: int = Field(..., description="Number of samples [-]")
    signals: list[str] = Field(..., description="Measured signals besides u [-]")
    scenario: dict[str, Any] = Field(..., description="Context: locked [-], x0 [m], ...")
    description: str = Field("", description="Free text")
    sample: Optional[str] = Field(None, description="Sample id for the shipped samples, else null")
    damaged: Optional[str] = Field(None, description="What cannot be read in the stored record "
                                   "(using it answers 409); null for a sound record [-]")


class DatasetCreated(DatasetInfo):
    import_: Optional[ImportReport] = Field(None, alias="import", description="How the file was read (not stored)")


class PreviewColumn(BaseModel):
    name: str = Field(..., description="Column as written in the file")
    unit: str = Field(..., description="Unit found in the header, the units row or the file's metadata; empty = none")
    signal: Optional[str] = Field(None, description="Proposed signal; null = no alias matches")


class FilePreview(BaseModel):
    format: str = Field(..., description="csv, tdms or mat")
    encoding: Optional[str] = Field(None, description="Detected text encoding (CSV)")
    delimiter: Optional[str] = Field(None, description="Detected delimiter (CSV)")
    decimal: Optional[str] = Field(None, description="Detected decimal mark (CSV)")
    units_row: Optional[bool] = Field(None, description="A units row was found (CSV)")
    columns: list[PreviewColumn] = Field(..., description="Columns in file order")
    mapping: dict[str, Optional[str]] = Field(..., description="Proposed mapping, column -> signal or null; send it back as the upload's columns field")
    rows: list[list[str]] = Field(..., description="The first data rows as text")
    signals: dict[str, dict[str, Any]] = Field(..., description="Every signal a column can map to, with its SI unit and the units accepted")


# ---------------------------------------------------------------------------- analysis responses
#: Said wherever an error appears: the API's errors are fractions, the page and reports show percent
FRACTION = "Eq. 25 normalised RMS error as a fraction, not percent (0.05 = 5 %) [-]"


class ShownCandidate(BaseModel):
    model_config = ConfigDict(extra="ignore")
    effect: str = Field(..., max_length=200, description="Effect name [-]")
    error_before: Optional[float] = Field(None, description=FRACTION)
    error_after_overall: Optional[float] = Field(None, description=FRACTION)
    lr_statistic: Optional[float] = Field(None, description="Likelihood-ratio statistic [-]")
    p_value: Optional[float] = Field(None, description="Its p-value [-]")
    delta_bic: Optional[float] = Field(None, description="Change of BIC [-]")
    params: dict[str, Any] = Field(default_factory=dict, description="Fitted parameters (units of the effect's parameters)")
    explanation: str = Field("", max_length=20_000, description="In words")
    model: Optional[dict[str, Any]] = Field(None, description="The model with the effect added (ModelIn)")


class ShownDiagnosis(BaseModel):
    """The parts of a diagnosis (POST /api/diagnose's answer) a report prints."""
    model_config = ConfigDict(extra="ignore")
    verdict: Optional[str] = Field(None, max_length=200, description="The effect named, or null [-]")
    message: str = Field("", max_length=50_000, description="The verdict in words")
    ranking: list[ShownCandidate] = Field(default_factory=list, description="Refitted candidates, best first")
    residual_tests: Optional[dict[str, Any]] = Field(None, description="Residual tests (their summary is printed)")


class DiagnoseReportRequest(DiagnoseRequest):
    diagnosis: Optional[ShownDiagnosis] = Field(None, description="The diagnosis on screen (POST /api/diagnose's answer for this model and these experiments): exported as it is, no new diagnosis is run; null = run one")



class ErrorSet(BaseModel):
    errors: dict[str, Optional[float]] = Field(..., description="Per signal (p_a, p_b, x, ...): " + FRACTION)
    overall: Optional[float] = Field(..., description="RMS of the per-signal errors: " + FRACTION)
    phases: dict[str, dict[str, Optional[float]]] = Field(default_factory=dict, description="Per command phase (initial, valve opens, valve closes, valve reverses) and signal: " + FRACTION)
    piston_phases: Optional[dict[str, dict[str, Optional[float]]]] = Field(None, description="Per piston phase (moving, stuck, at a stop, locked) and signal: " + FRACTION)


class FailureWindow(BaseModel):
    model_config = ConfigDict(extra="allow")
    description: str = Field(..., description="The window in words: experiment, signal, time span, phase")
    signal: Optional[str] = Field(None, description="Signal [-]")
    t0: Optional[float] = Field(None, description="Start of the window [s]")
    t1: Optional[float] = Field(None, description="End of the window [s]")
    energy: Optional[float] = Field(None, description="Share of the residual energy in the window [-]")


class ExperimentComparison(BaseModel):
    model_config = ConfigDict(extra="allow")
    name: str = Field(..., description="Experiment label")
    dataset_id: Optional[str] = Field(None, description="Stored dataset, if used")
    command_source: Optional[str] = Field(None, description="Where the replayed valve command came from: measured (the record's u) or scenario (given with the experiment) [-]")
    closed_loop: Optional[dict[str, Any]] = Field(None, description="A record made in closed loop (its scenario names the controller): {controller, command_source, note}; replayed open loop with its recorded valve command, the controller not simulated; absent for an open-loop record [-]")
    errors: dict[str, Optional[float]] = Field(..., description=FRACTION)
    overall: Optional[float] = Field(..., description=FRACTION)
    status: str = Field(..., description="Solver status of the replay")
    t: Optional[list[float]] = Field(None, description="Sample times on the model's axis (the measurement's t = 0) [s]")
    residuals: Optional[dict[str, list[Optional[float]]]] = Field(None, description="Model minus measured per signal (SI units: Pa, m, m/s, K); with residuals=true")
    simulated: Optional[dict[str, list[Optional[float]]]] = Field(None, description="Model per signal (SI units)")
    measured: Optional[dict[str, list[Optional[float]]]] = Field(None, description="Measured per signal (SI units)")


class ContextHint(BaseModel):
    experiment: str = Field(..., description="Experiment label")
    kind: str = Field(..., description="declared_free_never_moves or declared_locked_moves [-]")
    message: str = Field(..., description="What the record contradicts, and what to declare instead")


class SignalExcess(BaseModel):
    model_config = ConfigDict(extra="allow")
    experiment: str = Field(..., description="Experiment label")
    signal: str = Field(..., description="Signal (p_a, p_b, x, ...) [-]")
    n: int = Field(..., description="Samples of the phase in this experiment [-]")
    sigma: Optional[float] = Field(None, description="White measurement noise of the signal (SI unit of the signal: Pa, m, m/s, K)")
    rms: Optional[float] = Field(None, description="RMS of the residual, model minus measured, over the phase (SI unit of the signal)")
    ratio: Optional[float] = Field(None, description="rms / sigma: 1 is noise alone [-]")
    offset: Optional[float] = Field(None, description="Mean residual over the phase (SI unit of the signal)")
    start_offset: Optional[float] = Field(None, description=f"Mean residual over the phase's first {START_SAMPLES} samples: the initial state (SI unit of the signal)")
    start_sigmas: Optional[float] = Field(None, description="|start_offset| in its own standard errors, sigma / sqrt(samples) [-]")
    drift: Optional[float] = Field(None, description="Slope of an offset-and-straight-line fit of the residual (SI unit of the signal per second)")
    lag: Optional[float] = Field(None, description="Delay of the model from an offset-and-shift fit, positive when the model is late [s]")
    explained: dict[str, float] = Field(default_factory=dict, description="Share of the excess energy (residual less noise) that the offset, drift and lag fits each explain [-]")
    cause: str = Field(..., description="noise, offset, drift, lag, shape (none of the three alone) or too_few [-]")
    message: str = Field(..., description="The cause in words, numbers with units")


class PhaseExplanation(BaseModel):
    model_config = ConfigDict(extra="allow")
    worst_ratio: Optional[float] = Field(None, description="Largest residual RMS over noise sigma among the experiments and signals [-]")
    within_noise: bool = Field(..., description="Every signal's residual within the noise in this phase [-]")
    noise_floor: dict[str, Optional[float]] = Field(default_factory=dict, description="Eq. 25 error that the noise alone gives over this phase's samples, per signal and overall: " + FRACTION)
    message: str = Field(..., description="The phase's explanation in words")
    signals: list[SignalExcess] = Field(default_factory=list, description="Per experiment and signal")


class CompareResponse(ErrorSet):
    model_config = ConfigDict(extra="allow")
    combined_phases: dict[str, Any] = Field(default_factory=dict, description="Per command x piston phase and signal: " + FRACTION)
    failure_windows: list[FailureWindow] = Field(..., description="Where the model fails most, in words")
    noise_floor: dict[str, Optional[float]] = Field(..., description="Estimated measurement-noise floor of the error per signal: " + FRACTION)
    experiments: list[ExperimentComparison] = Field(..., description="Per experiment")
    heat_models: Optional[dict[str, Any]] = Field(None, description="The same comparison under each heat model asked for")
    hints: list[ContextHint] = Field(default_factory=list, description="Where a record contradicts the context declared with it (a free test that never moves, a locked one that does)")
    phase_explanations: dict[str, PhaseExplanation] = Field(default_factory=dict, description="Per command and piston phase: why its error stands above the noise (an offset, a drift, a lag) or that it is within the noise, from the residual")


class CalibrateResponse(BaseModel):
    model_config = ConfigDict(extra="allow")
    model: dict[str, Any] = Field(..., description="The fitted model (same JSON as the request's model): download it, or send it to simulate/compare")
    values: dict[str, dict[str, Any]] = Field(..., description="Per parameter path: value, stderr (unit of the parameter), init, min, max, vary (lmfit style)")
    correlations: dict[str, Any] = Field(..., description="Correlation of each pair of fitted parameters [-]")
    error_before: ErrorSet = Field(..., description="Errors of the starting model (fractions)")
    error_after: ErrorSet = Field(..., description="Errors of the fitted model (fractions)")
    aic: Optional[float] = Field(None, description="Akaike information criterion of the fit [-]")
    bic: Optional[float] = Field(None, description="Bayesian information criterion of the fit [-]")
    aic_before: Optional[float] = Field(None, description="AIC of the starting model [-]")
    bic_before: Optional[float] = Field(None, description="BIC of the starting model [-]")
    n_data: int = Field(..., description="Number of residuals [-]")
    n_params: int = Field(..., description="Number of fitted parameters [-]")
    known_disagree: Optional[list[dict[str, Any]]] = Field(None, description="With known: the declared values the data would move far (path, declared and data_suggest in the parameter's unit, residual_share [-], description); they are held")
    bench_held: list[str] = Field(default_factory=list, description="The bench-identified paths (model provenance) that the request listed in parameters, held at their bench value (vary false) [-]")
    success: bool = Field(..., description="The optimiser converged")
    message: str = Field(..., description="The optimiser's message")
    nfev: int = Field(..., description="Residual evaluations used [-]")


class ModelChange(BaseModel):
    path: str = Field(..., description="Parameter path (as in CalibrateRequest.parameters), or effects.<name> for an effect added or removed")
    before: Any = Field(None, description="Value now (the unit's SI value; 1 for a valve table's scale); null when added")
    after: Any = Field(None, description="Value after (SI); null when removed")
    unit: str = Field("", description="Unit of both values")
    kind: str = Field(..., description="changed, added, removed or scaled (a valve edge's table multiplied by 'after') [-]")


class ModelDiffRequest(_Strict):
    before: ModelIn = Field(..., description="The model as it was")
    after: ModelIn = Field(..., description="The model as it is now")


class RankingEntry(BaseModel):
    model_config = ConfigDict(extra="allow")
    effect: str = Field(..., description="Catalog effect")
    changes: list[ModelChange] = Field(default_factory=list, description="Every value of the model that taking this candidate changes (the effect and the base parameters recalibrated with it)")
    error_before: Optional[float] = Field(None, description="Overall error before adding it: " + FRACTION)
    error_after_overall: Optional[float] = Field(None, description="Overall error with it added and fitted: " + FRACTION)
    lr_statistic: Optional[float] = Field(None, description="Likelihood-ratio statistic (effective samples) [-]")
    p_value: Optional[float] = Field(None, description="p-value of the LR test [-]")
    delta_bic: Optional[float] = Field(None, description="BIC with the effect minus BIC without [-]")
    params: dict[str, Any] = Field(default_factory=dict, description="Fitted parameters (units in GET /api/effects)")
    explanation: Optional[str] = Field(None, description="The finding in words")
    held_off: Optional[list[str]] = Field(None, description="Its parameters held at off (the effect's smaller form): fitted on each experiment alone they disagreed, a stand-in; absent where every parameter was fitted [-]")
    stand_in: Optional[str] = Field(None, description="With held_off: the disagreement that made them a stand-in, in words")
    held_out_not_run: Optional[str] = Field(None, description="Why its held-out prediction was not made (a candidate ahead of it was named, so its flags are its LR test's and BIC's alone); absent where it was made or not needed")
    model: Optional[dict[str, Any]] = Field(None, description="The refitted model with the effect added")


class DiagnoseResponse(BaseModel):
    model_config = ConfigDict(extra="allow")
    verdict: Optional[str] = Field(..., description="The effect found, or null when no catalog effect explains the residual (see message)")
    message: str = Field(..., description="The verdict in words")
    ranking: list[RankingEntry] = Field(..., description="Refitted candidates, best first")
    score_pass: list[dict[str, Any]] = Field(..., description="The score test of every candidate")
    error_before: ErrorSet = Field(..., description="Errors of the diagnosed model (fractions)")
    failure_windows: list[FailureWindow] = Field(..., description="Where the model fails most")
    residual_tests: dict[str, Any] = Field(..., description="Ljung-Box and command cross-correlation tests of the residual")
    noise_floor: dict[str, Optional[float]] = Field(..., description="Noise floor per signal: " + FRACTION)
    base_model: dict[str, Any] = Field(..., description="The null model (uncertain parameters refitted)")
    uncertain: list[str] = Field(default_factory=list, description="Base parameter paths refitted along [-]")
    hints: list[ContextHint] = Field(default_factory=list, description="Where a record contradicts the context declared with it; also at the end of the message")
    changes: list[ModelChange] = Field(default_factory=list, description="Every value of the model that 'model' (the verdict applied) changes")
    recalibrate_effects: list[dict[str, Any]] = Field(default_factory=list, description="Parameters of the effects already in the model that the records moved (a line's length, a flow control's volume), refitted beside the base parameters: path, label, before, after, stderr, unit (the parameter's own: m, m^3, m^3/(s Pa)); 'model' carries them and the message names them")
    known: list[str] = Field(default_factory=list, description=KNOWN_DOC)
    bench_held: list[str] = Field(default_factory=list, description="The bench-identified paths (model provenance) that the request listed in uncertain, held at their bench value [-]")
    closed_loop: Optional[list[dict[str, Any]]] = Field(None, description="The experiments recorded in closed loop (their scenario names the controller): [{experiment, controller, command_source, note}], each replayed open loop with its recorded valve command; absent when none [-]")
    cluster: Optional[dict[str, Any]] = Field(None, description="Present when the work ran on the Dask cluster: 'lost' is null, or why the cluster was given up midway (no worker, no answer for the studies' grace time, a task lost) and the rest ran on this server, to the same answer [-]; null on this server alone")


class CalibrationParametersRequest(_Strict):
    model: ModelIn = Field(..., description="The model to fit")


class CalibrationOption(BaseModel):
    path: str = Field(..., description="Parameter path, as in CalibrateRequest.parameters")
    label: str = Field(..., description="What it is")
    value: float = Field(..., description="Current value (unit of the parameter; a scale factor for valve paths)")
    min: float = Field(..., description="Default lower bound used when the request gives none (unit of the parameter)")
    max: float = Field(..., description="Default upper bound used when the request gives none (unit of the parameter)")
    unit: str = Field(..., description="Unit of the parameter")


class HeatModelsResponse(BaseModel):
    runs: dict[str, SimulateResponse] = Field(..., description="One simulation per heat model")


from pneucore.data.command import OPEN_SHARE as _OPEN_SHARE  # noqa: E402


class CommandProposalRequest(_Strict):
    signal: Optional[Literal["p_a", "p_b"]] = Field(None, description="Chamber pressure the edges are read from; null = p_a if measured, else p_b [-]")
    open_level: Number = Field(1.0, ge=-1.0, le=1.0, description="Command while the pressure is held up, from a rise to the next fall [-]")
    closed_level: Number = Field(0.0, ge=-1.0, le=1.0, description="Command before the first rise and after each fall [-]")
    min_rate: Optional[Number] = Field(None, gt=0, description=f"Smallest pressure rate that opens the valve; null = {100 * _OPEN_SHARE:g} % of the record's fastest rise [Pa/s]")
    switching_time: Number = Field(0.0, ge=0.0, le=0.5, description="The valve's switching time after its command: the command's edges lead the signal's turns by it; 0 = the edges where the valve switched, for a model without switching time [s]")


class CommandProposal(BaseModel):
    command: list[list[Optional[float]]] = Field(..., description="Held command breakpoints [[t [s], u [-]], ...] on the record's time axis: give it back as the experiment's scenario.command once confirmed or edited")
    pulses: list[list[Optional[float]]] = Field(..., description="[[t_open [s], t_close [s] or null], ...]")
    signal: str = Field(..., description="The pressure the edges were read from [-]")
    threshold: float = Field(..., description="Pressure rate that made an edge [Pa/s]")
    edges: list[dict[str, Any]] = Field([], description="Per edge in time order: t (the command's edge) [s], turn (where the signal turns) [s], kind 'open'/'close', uncertainty (half-width of the times the data allow, about two standard errors) [s], sure (within two samples) [-]")
    source: str = Field(..., description="'proposed': read from the data, not measured; the user confirms it [-]")
    note: str = Field(..., description="How it was found, in words")
    has_command: bool = Field(..., description="The record has its own command column u (then it is used unless a scenario command is given) [-]")
    chamber_b: dict[str, Any] = Field({}, description="Chamber B's state proposed for a 3/2 valve from what the record shows: b_chamber (held, vented, closed or null: no proposal), b_chamber_pressure for held [Pa abs], sure [-], why (in words); the user sets valve.b_chamber")


class DatasetWithData(DatasetInfo):
    measurement: dict[str, Any] = Field(..., description="t [s], u [-] (absent when the record has no command), p_a/p_b [Pa abs], x [m], v [m/s], T_a/T_b [K], F [N], q_a/q_b/q_s [kg/s], p_s [Pa abs]; null = missing sample; meta.sensors: how each column was read on upload (unit, gain, offset, raw unit, gauge ambient [Pa])")


class StudyResultsResponse(BaseModel):
    """Results of a robustness study (GET /api/studies/{id}/results)."""
    model_config = ConfigDict(extra="allow")
    id: Optional[str] = Field(None, description="Study id")
    metrics: Optional[dict[str, Any]] = Field(None, description="Per metric: percentiles and moments, in the metric's unit")
    sensitivity: Optional[Any] = Field(None, description="Sensitivity ranking (PRCC / Spearman, or a variance decomposition for a full factorial) [-]")
    runs: Optional[list[dict[str, Any]]] = Field(None, description="Raw runs with their parameters and metrics (runs=true)")


# ---------------------------------------------------------------------------- catalog and records
# Every response model allows extra keys: a response never fails its own documentation when the
# library adds a field; the fields below are the documented contract.
class _Open(BaseModel):
    model_config = ConfigDict(extra="allow")


class PresetInfo(_Open):
    name: str = Field(..., description="Preset name (GET /api/presets/{name})")
    description: str = Field("", description="What it is")


class PresetList(_Open):
    models: list[PresetInfo] = Field(..., description="Model presets (a ModelIn each)")
    scenarios: list[PresetInfo] = Field(..., description="Scenario presets (a ScenarioIn each)")


class EffectParameterInfo(_Open):
    name: str = Field(..., description="Parameter name (path effects.<effect>.<name>)")
    unit: str = Field(..., description="SI unit of the parameter")
    default: float = Field(..., description="Value when the effect is added (in its unit)")
    min: float = Field(..., description="Lower bound of a fit (in its unit)")
    max: float = Field(..., description="Upper bound of a fit (in its unit)")
    off: Optional[float] = Field(..., description="Value at which the effect does nothing (in its unit); "
                                                  "null for a shape parameter (the effect is off through another one)")
    description: str = Field("", description="What it is")
    integer: bool = Field(False, description="A whole number, a count that shapes the model (a "
                                             "line's segments [-]): refused otherwise, never fitted")


class EffectInfo(_Open):
    name: str = Field(..., description="Effect name (the model's effects.<name>)")
    description: str = Field(..., description="The physics it adds")
    signature: str = Field(..., description="The residual it explains, in words")
    reference: str = Field("", description="Source of the law")
    parameters: list[EffectParameterInfo] = Field(..., description="Its parameters")
    user: bool = Field(False, description="Registered by a user rather than built in [-]")


class SampleExperiment(_Open):
    file: str = Field(..., description="CSV file of the sample")
    name: str = Field(..., description="Experiment label")
    scenario: dict[str, Any] = Field(..., description="Context: locked [-], x0 [m]")


class SampleInfo(_Open):
    id: str = Field(..., description="Sample id (dataset ids sample-<id>-<experiment>)")
    description: str = Field(..., description="What the rig data hide")
    base_model: str = Field(..., description="Model preset the sample was recorded against")
    experiments: list[SampleExperiment] = Field(..., description="Its experiments")


class SessionVersion(_Open):
    version: int = Field(..., description="0 = the base model [-]")
    label: str = Field(..., description="base, + <effect> or version N")
    created: float = Field(..., description="Creation time, Unix epoch [s]")
    model: dict[str, Any] = Field(..., description="The model of this version (ModelIn JSON)")
    errors: dict[str, Optional[float]] = Field(default_factory=dict, description="Per signal: " + FRACTION)
    overall: Optional[float] = Field(None, description="Overall: " + FRACTION)
    added: Optional[str] = Field(None, description="Catalog effect added in this version")
    params: Optional[dict[str, Any]] = Field(None, description="Fitted parameters of the added effect (units in GET /api/effects)")
    note: Optional[str] = Field(None, description="Free text")
    experiments: Optional[list[dict[str, Any]]] = Field(None, description="The experiments this version's errors were computed on (ExperimentIn); null in sessions stored before versions recorded them")


class SessionOut(_Open):
    id: str = Field(..., description="Session id")
    name: str = Field(..., description="Label")
    created: float = Field(..., description="Creation time, Unix epoch [s]")
    experiments: list[dict[str, Any]] = Field(..., description="The experiments every version is compared with (ExperimentIn)")
    versions: list[SessionVersion] = Field(..., description="Model versions, oldest first")


class SessionSummary(_Open):
    id: str = Field(..., description="Session id")
    name: str = Field(..., description="Label")
    created: float = Field(..., description="Creation time, Unix epoch [s]")
    n_versions: int = Field(..., description="Number of versions [-]")


class StudyStarted(_Open):
    id: str = Field(..., description="Study id")
    job_id: str = Field(..., description="Its job (GET /api/jobs/{id})")
    n_runs: Optional[int] = Field(None, description="Runs of the study [-]")
    status: str = Field(..., description="queued")


class StudyStatus(_Open):
    id: str = Field(..., description="Study id")
    status: str = Field(..., description="queued, running, done, interrupted, failed")
    n_runs: Optional[int] = Field(None, description="Runs of the study [-]")
    stored: Optional[int] = Field(None, description="Runs stored so far [-]")
    failed: Optional[int] = Field(None, description="Runs whose simulation failed [-]")
    job: Optional[dict[str, Any]] = Field(None, description="The latest job running it, when this server started one")


class ClusterInfo(_Open):
    name: str = Field(..., description="Name a study request may give in scheduler")
    kind: str = Field(..., description="What it is")
    default: bool = Field(..., description="Used when the request gives none [-]")
    max_workers: Optional[int] = Field(None, description="Largest worker count of the local pool [-]")


class HeatParameterInfo(_Open):
    name: str = Field(..., description="Parameter name (model path heat.<name>)")
    unit: str = Field(..., description="SI unit")
    default: float = Field(..., description="Default (in its unit)")
    min: float = Field(..., description="Lower bound (in its unit)")
    max: float = Field(..., description="Upper bound (in its unit)")
    description: str = Field("", description="What it is")


class HeatModelInfo(_Open):
    name: str = Field(..., description="Heat model name (the model's heat.model)")
    description: str = Field(..., description="The law and its source")
    parameters: list[HeatParameterInfo] = Field(..., description="Its parameters")


class HeatModelFit(_Open):
    name: str = Field(..., description="Heat model")
    description: str = Field("", description="The law and its source")
    parameters: dict[str, Any] = Field(..., description="Fitted heat parameters: value, stderr... (units in GET /api/heat-models)")
    errors: dict[str, Optional[float]] = Field(..., description="Per measured signal: " + FRACTION)
    temperature_rms: dict[str, Optional[float]] = Field(..., description="RMS gas-temperature error per temperature signal [K]")
    model: dict[str, Any] = Field(..., description="The calibrated model (ModelIn JSON)")
    message: str = Field("", description="The calibration's message")
    t: list[float] = Field(..., description="Sample times of the first experiment [s]")
    simulated: dict[str, list[Optional[float]]] = Field(..., description="The calibrated model on the first experiment, per signal (SI units)")


class HeatModelsCompareResponse(_Open):
    models: list[HeatModelFit] = Field(..., description="One row per heat model, each calibrated on its own parameters")
    measured: dict[str, list[Optional[float]]] = Field(..., description="The first experiment's measurement, per signal (SI units; t [s] from its first sample)")
    experiment: str = Field(..., description="The first experiment's label")


class RefineVersion(_Open):
    version: int = Field(..., description="0 = the starting model [-]")
    label: str = Field(..., description="base, + <effect>, or recalibrated: <parameters>")
    model: dict[str, Any] = Field(..., description="The model of this version (ModelIn JSON)")
    errors: dict[str, Optional[float]] = Field(..., description="Per signal: " + FRACTION)
    overall: Optional[float] = Field(..., description="Overall: " + FRACTION)
    added: Optional[str] = Field(None, description="Catalog effect added at this step")
    recalibrated: list[dict[str, Any]] = Field(default_factory=list, description="Parameters corrected at this step (mis-set base parameters, and those of effects already in the model the records moved): path, before, after, stderr, unit")


class RefineResponse(_Open):
    model: dict[str, Any] = Field(..., description="The refined model (ModelIn JSON), ready for the next test")
    versions: list[RefineVersion] = Field(..., description="One version per step: the error falling")
    diagnoses: list[DiagnoseResponse] = Field(..., description="The diagnosis of each round")
    closed_loop: Optional[list[dict[str, Any]]] = Field(None, description="The experiments recorded in closed loop, as in the diagnosis: each replayed open loop with its recorded valve command [-]")
    message: str = Field(..., description="The last round's finding in words")
    at_floor: bool = Field(..., description="The error reached the noise floor [-]")


def _limits_response():
    """GET /api/limits, field by field from :class:`app.config.Limits` (one source for the names
    and types), plus the deployment settings the service adds."""
    from dataclasses import fields

    from pydantic import create_model

    from .config import Limits
    types = {"int": int, "float": float}
    return create_model(
        "LimitsResponse", __base__=_Open,
        **{f.name: (f.type if isinstance(f.type, type) else types.get(f.type, Any), Field(..., description=f"Limits.{f.name} (README: REST API)"))
           for f in fields(Limits)},
        allowed_hosts=(list[str], Field(..., description="Host names the server answers to")),
        token_required=(bool, Field(..., description="Every request needs the bearer token [-]")))


LimitsResponse = _limits_response()


# ---------------------------------------------------------------------------- request examples
def _examples():
    """Request examples built from the presets (one source for the numbers)."""
    from pneucore.description.presets import model_preset, scenario_preset
    m4 = model_preset("paper-4way")
    exps = [{"dataset_id": "sample-leak-and-lag-locked-hold"},
            {"dataset_id": "sample-leak-and-lag-free-pulses"}]
    return {
        SimulateRequest: {"model": m4, "scenario": scenario_preset("paper-fig10-pulses"),
                          "series": ["t", "u", "p_a", "p_b", "x"]},
        CompareRequest: {"model": m4, "experiments": exps, "residuals": False},
        CalibrateRequest: {"model": m4, "experiments": exps, "parameters": {
            "jack.moving_mass": {"min": 0.5, "max": 10.0},
            "friction.extend.fc0": {"min": 0.0, "max": 50.0}}, "max_nfev": 40},
        DiagnoseRequest: {"model": m4, "experiments": exps, "uncertain": ["friction.extend.fc0"]},
        StudyRequest: {"model": m4, "scenario": scenario_preset("paper-fig10-pulses"), "parameters": {
            "friction.extend.fc0": {"distribution": "uniform", "min": 4, "max": 16},
            "supply.pressure": {"distribution": "normal", "mean": 6e5, "std": 4e4,
                                "min": 4.5e5, "max": 7.5e5}}, "samples": 200, "seed": 1},
    }


for _cls, _ex in _examples().items():
    _cls.model_config["json_schema_extra"] = {"examples": [_ex]}
    _cls.model_rebuild(force=True)


# ---------------------------------------------------------------------------- friction preview
from typing import Annotated  # noqa: E402 - kept with the schemas that use it

#: Bounds of a friction-preview grid (POST /api/friction/preview): at most this many pressure
#: pairs and velocities per request, velocities within +-FRICTION_V_MAX [m/s] and pressures
#: within (0, FRICTION_P_MAX] [Pa abs]
FRICTION_MAX_PRESSURES = 20
FRICTION_MAX_VELOCITIES = 2001
FRICTION_V_MAX = 100.0
FRICTION_P_MAX = 1e9
#: The velocity grid when a request gives none: -0.6 to 0.6 m/s in 0.01 m/s steps [m/s]
FRICTION_DEFAULT_VELOCITIES = tuple(round(i / 100, 2) for i in range(-60, 61))

_Pressure = Annotated[float, Field(gt=0.0, le=FRICTION_P_MAX, allow_inf_nan=False)]
_Velocity = Annotated[float, Field(ge=-FRICTION_V_MAX, le=FRICTION_V_MAX, allow_inf_nan=False)]


class FrictionPressures(_Strict):
    p_a: _Pressure = Field(..., description=f"Chamber A absolute pressure, above 0 and at most {FRICTION_P_MAX:g} [Pa]")
    p_b: _Pressure = Field(..., description=f"Chamber B absolute pressure, above 0 and at most {FRICTION_P_MAX:g} [Pa]")


class FrictionPreviewRequest(_Strict):
    model: ModelIn = Field(..., description="The model whose friction is mapped (its friction law, coefficients and friction effects such as stribeck_friction)")
    pressures: list[FrictionPressures] = Field(..., min_length=1, max_length=FRICTION_MAX_PRESSURES, description=f"Chamber pressure pairs, one curve each (1 to {FRICTION_MAX_PRESSURES}) [Pa]")
    velocities: Optional[list[_Velocity]] = Field(None, min_length=1, max_length=FRICTION_MAX_VELOCITIES, description=f"Piston velocities, each within +-{FRICTION_V_MAX:g} (1 to {FRICTION_MAX_VELOCITIES}); null = -0.6 to 0.6 in 0.01 steps [m/s]")


class FrictionCurve(_Open):
    p_a: float = Field(..., description="Chamber A absolute pressure [Pa]")
    p_b: float = Field(..., description="Chamber B absolute pressure [Pa]")
    force: list[Optional[float]] = Field(..., description="Sliding friction force at each velocity, positive when it points towards -x (it opposes extension); null at v = 0, where the piston sticks (see static_extend, static_retract) [N]")
    static_extend: float = Field(..., description="Static (breakaway) limit towards +x: at rest the piston sticks while the net force lies within [-static_retract, static_extend] [N]")
    static_retract: float = Field(..., description="Static (breakaway) limit towards -x, as a magnitude [N]")
    coulomb_extend: float = Field(..., description="Coulomb level Fc(p) of the extension coefficients (Eq. 20) [N]")
    coulomb_retract: float = Field(..., description="Coulomb level Fc(p) of the retraction coefficients (Eq. 20) [N]")
    viscous_extend: float = Field(..., description="Viscous coefficient Kv(p) of the extension coefficients (Eq. 19) [N s/m]")
    viscous_retract: float = Field(..., description="Viscous coefficient Kv(p) of the retraction coefficients (Eq. 19) [N s/m]")


class FrictionPreviewResponse(_Open):
    law: str = Field(..., description="The model's friction law by name [-]")
    stribeck_ratio: float = Field(..., description="Static over Coulomb friction; 1 = no Stribeck effect [-]")
    stribeck_velocity: float = Field(..., description="Stribeck velocity of the breakaway term [m/s]")
    velocities: list[float] = Field(..., description="The piston velocities of every curve [m/s]")
    curves: list[FrictionCurve] = Field(..., description="One friction curve per pressure pair, in the request's order [N]")
