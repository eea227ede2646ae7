"""Schemas of the step-by-step identification (POST /api/identify/valve and /friction).

Units are SI, pressures absolute, as everywhere in the API; pneucore checks the physics
(a downstream pressure above the upstream one, a negative flow, an opening outside the
valve's range, a record without its force) and the API answers 422 naming the field.
"""
from __future__ import annotations

from typing import Any, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field

from pneucore.identify.friction_bench import EXTRAS, RIG_COLUMNS, WINDOW

from .schemas import ModelIn, Name

#: Bench points per valve request [-]
MAX_BENCH_POINTS = 20_000
#: Records per friction request (fitted and validated each) [-]
MAX_FRICTION_RECORDS = 16
#: Samples per friction record [-]: a 100 Hz record of about 30 minutes
MAX_RECORD_SAMPLES = 200_000


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class _Open(BaseModel):
    model_config = ConfigDict(extra="allow")


class BenchPointIn(_Strict):
    opening: Optional[float] = Field(None, description="Spool opening; null for a fixed orifice (every point then) [-]")
    p_up: float = Field(..., description="Upstream absolute pressure [Pa]")
    p_down: float = Field(..., description="Downstream absolute pressure, at most p_up [Pa]")
    T_up: float = Field(..., description="Upstream gas temperature [K]")
    flow: float = Field(..., description="Mass flow from upstream to downstream, >= 0 [kg/s]")


class ValveIdentifyRequest(_Strict):
    edge: str = Field("P-A", description="Metering edge the points were measured on: P-A, A-R, P-B or B-R [-]")
    points: list[BenchPointIn] = Field(..., min_length=1, max_length=MAX_BENCH_POINTS,
                                       description=f"Bench points, steady or a slow sweep (1 to {MAX_BENCH_POINTS}) [-]")
    model: Optional[ModelIn] = Field(None, description="A model to write the identified table into (its valve's opening range and laminar_ratio apply); null = none, a 4/2 valve's range -1..1 and the default laminar ratio")
    openings: Optional[list[float]] = Field(None, max_length=200, description="Table openings to group a sweep's points on (each point to the nearest); null = every distinct opening of the points [-]")


class EdgeTableOut(_Open):
    opening: list[Optional[float]] = Field(..., description="Table openings, increasing; [null] for a fixed orifice [-]")
    C: list[Optional[float]] = Field(..., description="Sonic conductance at each opening, the model's unit [m^3/(s Pa)]")
    b: list[Optional[float]] = Field(..., description="Critical pressure ratio at each opening [-]")


class BenchResidual(_Open):
    opening: Optional[float] = Field(None, description="The point's opening [-]")
    flow: float = Field(..., description="Measured mass flow [kg/s]")
    flow_model: float = Field(..., description="Mass flow of the identified law (ISO 6358, Eq. 4-5, linearised above laminar_ratio as in the model) [kg/s]")
    residual: float = Field(..., description="Measured minus model [kg/s]")
    ratio: float = Field(..., description="p_down / p_up [-]")


class ValveIdentifyResponse(_Open):
    name: str = Field(..., description="The edge's name [-]")
    edge: EdgeTableOut = Field(..., description="The identified table: opening [-], C [m^3/(s Pa)], b [-]")
    table: EdgeTableOut = Field(..., description="The table as the model's valve holds it (a fixed orifice: its C and b over the valve's whole range) [-]")
    C_se: list[Optional[float]] = Field(..., description="Standard error of each C; null where the points fit exactly [m^3/(s Pa)]")
    b_se: list[Optional[float]] = Field(..., description="Standard error of each b; null where b was not fitted [-]")
    b_fitted: list[bool] = Field(..., description="False where b was copied from the nearest open opening (a closed opening) [-]")
    closed: list[bool] = Field(..., description="True at the openings of the null / overlap band [-]")
    null_band: Optional[dict[str, Optional[float]]] = Field(None, description="low, high: the closed openings' range; onset_low, onset_high: where C(u) extrapolates to zero beside it [-]")
    fixed_orifice: bool = Field(..., description="The points had no opening: one C and one b [-]")
    laminar_ratio: float = Field(..., description="Pressure ratio above which the law is linearised, as in the model [-]")
    points: list[BenchResidual] = Field(..., description="Every point with its residual [kg/s]")
    rms_residual: float = Field(..., description="Rms of the points' residuals [kg/s]")
    units: dict[str, str] = Field(..., description="Unit of each quantity [-]")
    report: str = Field(..., description="Plain-text table, C in dm^3/(s bar) [-]")
    model: Optional[dict[str, Any]] = Field(None, description="The request's model with this edge's table written in (null when no model was given); the API's other routes accept it as it is [-]")


class FrictionRecordIn(_Open):
    """A friction-bench record; a measurement's other signals (u, v, T_a, ...) are accepted
    and not used."""
    name: Optional[Name] = Field(None, description="Label [-]")
    t: Optional[list[Optional[float]]] = Field(None, max_length=MAX_RECORD_SAMPLES, description="Sample times, increasing [s]")
    x: Optional[list[Optional[float]]] = Field(None, max_length=MAX_RECORD_SAMPLES, description="Piston position, extension positive [m]")
    p_a: Optional[list[Optional[float]]] = Field(None, max_length=MAX_RECORD_SAMPLES, description="Chamber A absolute pressure [Pa]")
    p_b: Optional[list[Optional[float]]] = Field(None, max_length=MAX_RECORD_SAMPLES, description="Chamber B absolute pressure [Pa]")
    F: Optional[list[Optional[float]]] = Field(None, max_length=MAX_RECORD_SAMPLES, description="Rod force on its load, positive outward (towards +x) [N]; required")
    measurement: Optional[dict[str, Any]] = Field(None, description="The same signals (t [s], x [m], p_a, p_b [Pa abs], F [N]) nested, as a measurement object, instead of beside name [-]")
    dataset_id: Optional[str] = Field(None, description="A stored dataset (POST /api/datasets: a rig file with t, x, p_a, p_b and the rod force F mapped, in any unit the importer reads: N, kN, daN, lbf) instead of the signals inline [-]")


class FrictionIdentifyRequest(_Strict):
    model: ModelIn = Field(..., description="The jack (areas, rods, moving mass) and ambient pressure; its friction gives the parameters the records cannot identify")
    experiments: list[FrictionRecordIn] = Field(..., min_length=1, max_length=MAX_FRICTION_RECORDS, description=f"Prescribed-motion records to fit on (1 to {MAX_FRICTION_RECORDS}) [-]")
    validate_: list[FrictionRecordIn] = Field([], alias="validate", max_length=MAX_FRICTION_RECORDS, description="Records not fitted on: the identified model predicts their rod force [-]")
    extras: list[Literal[tuple(EXTRAS)]] = Field([], description="Also identify: load-cell offset [N], effective area minus the model's in A or B [m^2], moving mass [kg]")
    stribeck: Union[bool, Literal["auto"]] = Field("auto", description="Breakaway term (stribeck_friction effect): auto = kept only where the data show it, true = kept, false = none [-]")
    quadrant: bool = Field(True, description="One friction set per direction (the model's form); false = one set for both [-]")
    v_min: Optional[float] = Field(None, ge=0.0, le=10.0, description="Samples slower than this are reversals, not fitted; null = a tenth of the 95th-percentile speed [m/s]")
    window: float = Field(WINDOW, gt=0.0, le=5.0, description="Window of the acausal differentiating filter (Savitzky-Golay) [s]")

    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class DirectionErrors(_Open):
    rms: Optional[float] = Field(None, description="Rms of predicted minus measured rod force [N]")
    mean: Optional[float] = Field(None, description="Mean of predicted minus measured rod force [N]")
    n: int = Field(..., description="Samples counted [-]")


class FrictionValidation(_Open):
    name: str = Field(..., description="The record's label [-]")
    t: list[float] = Field(..., description="Sample times [s]")
    force: list[float] = Field(..., description="Rod force predicted by the identified model (Eq. 17) at every sample [N]")
    measured: list[float] = Field(..., description="Measured rod force [N]")
    rms: Optional[float] = Field(None, description="Rms of predicted minus measured over the sliding samples [N]")
    mean: Optional[float] = Field(None, description="Mean of predicted minus measured over the sliding samples [N]")
    n: int = Field(..., description="Sliding samples counted (faster than v_min) [-]")
    extend: DirectionErrors = Field(..., description="The errors while extending (v > 0) [N]")
    retract: DirectionErrors = Field(..., description="The errors while retracting (v < 0) [N]")
    v_min: float = Field(..., description="Speed below which samples are left out of the errors [m/s]")
    errors: dict[str, Any] = Field(..., description="The same errors grouped: rms, mean [N], n [-], extend and retract [N]")


class FrictionIdentifyResponse(_Open):
    model: dict[str, Any] = Field(..., description="The request's model with the identified friction (and stribeck_friction, moving mass when identified); the API's other routes accept it as it is [-]")
    parameters: dict[str, dict[str, Any]] = Field(..., description="Each parameter by name: value, se (standard error), unit, identified (false: held at the model's value, reason says why), at_bound [-]")
    correlations: dict[str, Any] = Field(..., description="names and matrix of the identified parameters' correlations [-]")
    rms: float = Field(..., description="Rms force residual over the fitted samples [N]")
    levels: list[dict[str, Any]] = Field(..., description="Per pressure level and direction: p_a, p_b gauge [Pa], measured and model mean friction [N], mean_residual [N], se [N], relative [-]")
    linear_in_pressure: Optional[bool] = Field(None, description="False when the friction is not linear in pressure (Eq. 19-20 do not hold; warnings say where); null with fewer than three pressure levels [-]")
    warnings: list[str] = Field(..., description="What did not hold [-]")
    friction_map: list[dict[str, Any]] = Field(..., description="Per record and direction: measured friction binned in velocity [m/s] against the law's [N] (paper Fig. 4)")
    v_min: float = Field(..., description="Speed below which samples were not fitted [m/s]")
    tau: float = Field(..., description="Integrated autocorrelation time of the residuals; the standard errors include its square root [samples]")
    stribeck: Optional[dict[str, Any]] = Field(None, description="The breakaway term's trial: static_ratio [-], stribeck_velocity [m/s], se_ratio [-], rms_without, rms_with [N], kept, shown_by_data")
    quadrant: bool = Field(..., description="One friction set per direction [-]")
    report: str = Field(..., description="Plain-text report [-]")
    validation: list[FrictionValidation] = Field(..., description="One entry per validate record, in order: predicted rod force and its errors [N]")


class BenchFileOut(_Open):
    name: str = Field(..., description="The record's label: the file name without its extension [-]")
    samples: int = Field(..., description="Samples read [-]")
    duration: float = Field(..., description="Last minus first sample time [s]")
    p_a_median: float = Field(..., description="Median chamber A absolute pressure [Pa]")
    p_b_median: float = Field(..., description="Median chamber B absolute pressure (the ambient when the file has no p_b) [Pa]")
    stroke: float = Field(..., description="Range of the position [m]")


class FrictionRecordOut(_Open):
    name: str = Field(..., description="Label [-]")
    t: list[float] = Field(..., description="Sample times [s]")
    x: list[float] = Field(..., description="Piston position, extension positive [m]")
    p_a: list[float] = Field(..., description="Chamber A absolute pressure [Pa]")
    p_b: list[float] = Field(..., description="Chamber B absolute pressure [Pa]")
    F: list[float] = Field(..., description="Rod force on its load, positive outward [N]")


class FrictionRecordsResponse(_Open):
    records: list[FrictionRecordOut] = Field(..., description="One record per file, in order, in SI units: POST /api/identify/friction takes them as they are (experiments or validate) [-]")
    files: list[BenchFileOut] = Field(..., description="What was read from each file [-]")
    columns: list[Optional[str]] = Field(..., description="The layout read: one label per column (signal[unit], a leading - negates; null: not read) [-]")
    ambient_pressure: float = Field(..., description="Ambient pressure added to gauge readings, and chamber B's when not measured [Pa]")
    warnings: list[str] = Field(..., description="What was assumed: chamber B at ambient when the files have no p_b, the default layout [-]")


_RIG = ", ".join("-" if c is None else c for c in RIG_COLUMNS)
_COLUMNS_DOC = (f"The files' columns in order, comma-separated or a JSON list: signal[unit] with the "
                f"importer's units (t[s|ms], x[m|mm], p_a, p_b[Pa|kPa|bar|bar(g)...], F[N|kN|daN|lbf]), "
                f"a leading - to negate x or F, - for a column not read; t, x, p_a and F are needed, "
                f"without p_b chamber B is at ambient. Default: the TU Delft friction bench's "
                f"({_RIG}). Form field or query parameter")
#: The upload's form in the OpenAPI document (POST /api/identify/friction/records reads its body itself)
RECORDS_UPLOAD_DOC = {
    "requestBody": {"content": {
        "multipart/form-data": {"schema": {"type": "object", "required": ["file"], "properties": {
            "file": {"type": "array", "items": {"type": "string", "format": "binary"},
                     "description": f"One to {MAX_FRICTION_RECORDS} bench files as the rig writes them: "
                                    f"no header, one sample a line (at most {MAX_RECORD_SAMPLES}), "
                                    "values separated by blanks, tabs, commas or semicolons"},
            "columns": {"type": "string", "description": _COLUMNS_DOC},
            "ambient_pressure": {"type": "number", "description": "Ambient pressure, added to gauge "
                                 "readings and chamber B's when not measured [Pa]"}}}},
        "text/plain": {"schema": {"type": "string", "description": "One bench file as the body "
                                                                   "(columns, ambient_pressure, filename "
                                                                   "in the query)"}}}}}
