"""Pydantic schemas of the sizing API (POST /api/sizing, POST /api/jobs/sizing).

The requirement's and the choices' fields mirror :class:`pneucore.sizing.Requirement` and
:class:`pneucore.sizing.Choices`: their defaults and descriptions (with units) are read from
those dataclasses, the one source (tests/sizing/test_sizing_api_schema.py checks it).
Pydantic checks types and shapes; pneucore checks the physics and its bounds, and its
``FieldError`` becomes a 422 naming the field and its unit.
"""
from __future__ import annotations

import copy
from typing import Any, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, StrictBool

from pneucore.sizing.requirement import Choices, Requirement
from pneucore.sizing.search import REASONS
from pneucore.sizing.stroke import STROKE_METRIC_UNITS
from pneucore.description.docstrings import api_description
from pneucore.description.valve_data import FIELDS as VALVE_FIELDS

from .schemas import Name

#: Most items of one choices list (a series name counts as one)
MAX_CHOICE_ITEMS = 200

_REQ, _CH = Requirement(), Choices()


def _lib(cls, obj, name, required=False):
    """A Field with the pneucore field's description, and its default unless required."""
    desc = api_description(cls, name)
    if required:
        return Field(..., description=desc)
    value = getattr(obj, name)
    if isinstance(value, list):
        return Field(default_factory=lambda: copy.deepcopy(value), description=desc,
                     max_length=MAX_CHOICE_ITEMS)
    return Field(value, description=desc)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class CushionCapacitySpec(_Strict):
    bore: float = Field(..., description="Bore (piston) diameter this capacity is for [m]")
    capacity: float = Field(..., description="The cushion's allowable kinetic energy at that "
                                             "bore, as the catalogue gives it [J]")
    series: Optional[Name] = Field(None, description="Cylinder series it is for (iso6432); "
                                                     "null = every series with that bore [-]")


class RequirementSpec(_Strict):
    stroke: float = _lib(Requirement, _REQ, "stroke", required=True)
    moving_mass: float = _lib(Requirement, _REQ, "moving_mass", required=True)
    load_force: float = _lib(Requirement, _REQ, "load_force")
    angle: float = _lib(Requirement, _REQ, "angle")
    supply_pressure: float = _lib(Requirement, _REQ, "supply_pressure", required=True)
    extend_time: Optional[float] = _lib(Requirement, _REQ, "extend_time")
    retract_time: Optional[float] = _lib(Requirement, _REQ, "retract_time")
    cycle_time: Optional[float] = _lib(Requirement, _REQ, "cycle_time")
    dwell: float = _lib(Requirement, _REQ, "dwell")
    max_end_speed: Optional[float] = _lib(Requirement, _REQ, "max_end_speed")
    max_end_energy: Optional[float] = _lib(Requirement, _REQ, "max_end_energy")
    cushion_length: Optional[float] = _lib(Requirement, _REQ, "cushion_length")
    cushion_capacity: Optional[float] = _lib(Requirement, _REQ, "cushion_capacity")
    tube_length: Optional[float] = _lib(Requirement, _REQ, "tube_length")
    ambient_pressure: float = _lib(Requirement, _REQ, "ambient_pressure")
    valve_on_time: float = _lib(Requirement, _REQ, "valve_on_time")
    valve_off_time: float = _lib(Requirement, _REQ, "valve_off_time")
    cushion_capacities: list[CushionCapacitySpec] = _lib(Requirement, _REQ, "cushion_capacities")
    max_load_factor: float = _lib(Requirement, _REQ, "max_load_factor")
    min_buckling_safety: float = _lib(Requirement, _REQ, "min_buckling_safety")


class CylinderSpec(_Strict):
    bore: float = Field(..., description="Bore (piston) diameter [m]")
    rod: float = Field(0.0, description="Rod diameter, on the chamber-B side [m]")
    name: Optional[Name] = Field(None, description="Label [-]")


def _figure(name):
    """A catalogue figure's field, described from :mod:`pneucore.description.valve_data` (the one source)."""
    unit, desc, _, default = VALVE_FIELDS[name]
    return Field(None, description=f"Instead of C, for the valve converter: {desc}"
                                   + ("" if default is None else f"; null = {default:g}")
                                   + f" [{unit}]")


class ValveSpec(_Strict):
    C: Optional[float] = Field(None, description="Sonic conductance of the supply edges P-A, P-B; "
                                                 "null = from one catalogue figure (qn, "
                                                 "effective_area or flow_rate with p1, p2) "
                                                 "[m^3/(s Pa)]")
    qn: Optional[float] = _figure("qn")
    effective_area: Optional[float] = _figure("effective_area")
    flow_rate: Optional[float] = _figure("flow_rate")
    p1: Optional[float] = _figure("p1")
    p2: Optional[float] = _figure("p2")
    T1: Optional[float] = _figure("T1")
    b: float = Field(..., description="Critical pressure ratio of the supply edges [-]")
    C_exhaust: Optional[float] = Field(None, description="Sonic conductance of the exhaust edges "
                                                         "A-R, B-R; null = as C [m^3/(s Pa)]")
    b_exhaust: Optional[float] = Field(None, description="Critical pressure ratio of the exhaust "
                                                         "edges; null = as b [-]")
    name: Optional[Name] = Field(None, description="Label [-]")


class ChoicesSpec(_Strict):
    bore: list[Union[Name, CylinderSpec]] = _lib(Choices, _CH, "bore")
    valve: list[Union[Name, ValveSpec]] = _lib(Choices, _CH, "valve")
    tube_inner_diameter: list[Union[Name, float]] = _lib(Choices, _CH, "tube_inner_diameter")
    meter_out: StrictBool = _lib(Choices, _CH, "meter_out")
    min_meter_out: float = _lib(Choices, _CH, "min_meter_out")

    def plain(self):
        """Plain JSON for pneucore (unset optional values left out)."""
        return self.model_dump(exclude_none=True)


_EXAMPLE = {"requirement": {"stroke": 0.2, "moving_mass": 5.0, "load_force": 50.0, "angle": 30.0,
                            "supply_pressure": 7e5, "extend_time": 0.6, "retract_time": 0.6,
                            "max_end_speed": 1.0},
            "choices": {"bore": ["iso15552", "iso6432:20", "iso6432:25"], "valve": ["ckd-4ga"]}}


class SizingRequest(_Strict):
    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [_EXAMPLE]})
    requirement: RequirementSpec = Field(..., description="The required motion (SI units, "
                                                          "absolute pressures)")
    choices: ChoicesSpec = Field(default_factory=ChoicesSpec,
                                 description="What may vary; every list empty = the shipped series")

    def plain(self):
        """``(requirement, choices)`` as plain JSON for :func:`pneucore.sizing.size`."""
        return self.requirement.model_dump(exclude_none=True), self.choices.plain()


# ------------------------------------------------------------------------------- answers
class CylinderOut(BaseModel):
    series: Optional[str] = Field(None, description="Series it comes from; null = the user's own [-]")
    name: str = Field(..., description="series:member, or the user's label [-]")
    bore: float = Field(..., description="Bore diameter [m]")
    rod: float = Field(..., description="Rod diameter [m]")


class ValveOut(BaseModel):
    series: Optional[str] = Field(None, description="Series it comes from; null = the user's own [-]")
    name: str = Field(..., description="series:member, or the user's label [-]")
    C: float = Field(..., description="Sonic conductance of the supply edges [m^3/(s Pa)]")
    b: float = Field(..., description="Critical pressure ratio of the supply edges [-]")
    C_exhaust: float = Field(..., description="Sonic conductance of the exhaust edges [m^3/(s Pa)]")
    b_exhaust: float = Field(..., description="Critical pressure ratio of the exhaust edges [-]")
    qn: float = Field(..., description="ISO 6358 nominal flow of the supply edge, from C and b "
                                       "(6 bar gauge in, 1 bar drop) [NL/min]")


class TubeOut(BaseModel):
    series: Optional[str] = Field(None, description="Series it comes from; null = the user's own [-]")
    name: str = Field(..., description="series:member or the inner diameter [-]")
    inner_diameter: float = Field(..., description="Inner diameter [m]")


def _metric_field(name):
    return Field(None, description=f"{name.replace('_', ' ')}; null = not reached "
                                   f"[{STROKE_METRIC_UNITS[name]}]")


class StrokeMetricsOut(BaseModel):
    start_up_time: Optional[float] = _metric_field("start_up_time")
    full_stroke_time: Optional[float] = _metric_field("full_stroke_time")
    mean_speed: Optional[float] = _metric_field("mean_speed")
    max_speed: Optional[float] = _metric_field("max_speed")
    end_speed: Optional[float] = _metric_field("end_speed")
    end_energy: Optional[float] = _metric_field("end_energy")
    air: Optional[float] = _metric_field("air")


class DesignMetricsOut(BaseModel):
    extend: StrokeMetricsOut = Field(..., description="Full-stroke extension from rest at x = 0")
    retract: StrokeMetricsOut = Field(..., description="Full-stroke retraction from rest at x = stroke")
    units: dict[str, str] = Field(..., description="Unit of each metric")


class CushionStrokeOut(BaseModel):
    needle_C: float = Field(..., description="Sonic conductance of the needle of the end this "
                                             "stroke meets [m^3/(s Pa)]")
    needle_solved: bool = Field(..., description="Whether the needle was solved (false: fully "
                                                  "open, the stroke meets its end within the "
                                                  "capacity without it) [-]")
    end_speed: Optional[float] = Field(None, description="Piston speed at the impact; null = "
                                                         "not reached [m/s]")
    end_energy: Optional[float] = Field(None, description="Kinetic energy of the moving mass "
                                                          "at the impact; null = not reached [J]")
    energy_ratio: Optional[float] = Field(None, description="end_energy / the cushion's "
                                                            "capacity (at most 1 when feasible) "
                                                            "[-]")


class CushionOut(BaseModel):
    length: float = Field(..., description="Cushion length at each end (the requirement's) [m]")
    capacity: float = Field(..., description="Energy the cushion absorbs at most: the "
                                             "cylinder's own (requirement.cushion_capacities) "
                                             "or requirement.cushion_capacity [J]")
    capacity_source: Optional[str] = Field(None, description="Where the capacity comes from: "
                                                             "cushion_capacities[i] or "
                                                             "cushion_capacity [-]")
    needle_open_C: float = Field(..., description="The needle fully open: ten times the valve's "
                                                  "exhaust conductance [m^3/(s Pa)]")
    extend: CushionStrokeOut = Field(..., description="The x = stroke end (chamber B's needle)")
    retract: CushionStrokeOut = Field(..., description="The x = 0 end (chamber A's needle)")


class DesignOut(BaseModel):
    rank: int = Field(..., description="1 = best: the designs keeping a 20 % margin on every "
                                       "check first (margins), then least air per cycle, then "
                                       "smallest [-]")
    cylinder: CylinderOut
    valve: ValveOut
    tube: Optional[TubeOut] = Field(None, description="Tube on each port; null = no tube")
    settings: dict[str, float] = Field(..., description=(
        "Sonic conductance of each direction's meter-out throttle, the model's "
        "meter_out_throttle on the exhausting port (extend_meter_out_C: port B, "
        "retract_meter_out_C: port A; 0 = none) [m^3/(s Pa)], and the conductance of the whole "
        "exhaust path it leaves: throttle, tube and valve edge in series, ISO 6358-3 "
        "(extend_exhaust_C, retract_exhaust_C) [m^3/(s Pa)]; with a cushion in the "
        "requirement, each end's cushion needle (extend_needle_C: the x = stroke end, chamber "
        "B; retract_needle_C: the x = 0 end, chamber A) [m^3/(s Pa)]"))
    model: dict[str, Any] = Field(..., description="The design's model, as POST /api/simulate "
                                                   "accepts it")
    metrics: DesignMetricsOut
    air_per_cycle: float = Field(..., description="Air drawn from the supply per cycle (extension "
                                                  "and retraction), ANR [NL]")
    required_times: dict[str, float] = Field(..., description=(
        "Full-stroke time each direction was sized for (extend, retract): the requirement's, or "
        "with a cycle_time each direction's share of the time to move [s]"))
    cushion: Optional[CushionOut] = Field(None, description="The end cushions and their "
                                                            "needles; null = no cushion in the "
                                                            "requirement")
    steady_cycle: Optional[dict[str, Any]] = Field(None, description=(
        "The design's strokes in the machine's steady cycle, the state its strokes were sized "
        "from: scenario (the design's cycle, start: cyclic, as POST /api/simulate accepts it), "
        "full_stroke_time {extend, retract} [s], end_speed {extend, retract} [m/s], cycles "
        "repeated [-], converged [-], start (p_a, p_b [Pa abs], T_a, T_b [K], x0 [m], v0 "
        "[m/s]); null for a closest infeasible design beyond the first ranked"))
    stroke_starts: Optional[dict[str, dict[str, float]]] = Field(None, description=(
        "The state each stroke of the sizing starts from {extend, retract}: p_a, p_b [Pa abs], "
        "T_a, T_b [K], the steady cycle's at that stroke's command; null = the default start "
        "(exhausting chamber at the supply, gases at the model's temperature)"))
    margins: Optional[dict[str, Any]] = Field(None, description=(
        "Each check's headroom as a share of its limit: load_factor (1 - factor / limit), "
        "buckling (1 - minimum / safety), cushion (1 - impact energy / capacity) [-]; least "
        "[-]; ok: every one at least 0.2, ranked before the designs without [-]"))
    checks: Optional[dict[str, Any]] = Field(None, description=(
        "The cylinder makers' checks besides the motion: load_factor {extend, retract} (the "
        "static load over the theoretical output at the supply) [-] with load_factor_limits "
        "(SMC: static 0.7, on a guide 1.0, moving the load 0.5) [-], load_factor_limit "
        "(requirement.max_load_factor) [-] and load_factor_ok [-]; buckling_load (Euler, steel "
        "rod, one end fixed and one free, K = 2, over the stroke) [N], buckling_safety (it over "
        "the extension's theoretical output) [-], buckling_safety_min "
        "(requirement.min_buckling_safety) [-], buckling_ok [-]. A family failing either is "
        "rejected (infeasible, reasons load_factor, buckling)"))
    best_of_cylinder: Optional[bool] = Field(None, description="The first (least air) design of "
                                                               "its cylinder: the short list [-]")
    why: Optional[str] = Field(None, description="Why the design is where it is, in words")
    feasible: bool = Field(..., description="Meets the requirement (false: one of the closest "
                                            "families, shown when none meets it) [-]")


class InfeasibleOut(BaseModel):
    cylinder: CylinderOut
    valve: ValveOut
    tube: Optional[TubeOut] = None
    reason: str = Field(..., description="; ".join(f"{k}: {v}" for k, v in REASONS.items()) + " [-]")
    direction: Optional[str] = Field(None, description="extend or retract; null = both or "
                                                       "neither [-]")
    detail: str = Field(..., description="The numbers behind the reason, with units")


class SizingResponse(BaseModel):
    summary: str = Field(..., description="One line: how many families meet the requirement, "
                                          "or why none does")
    designs: list[DesignOut] = Field(..., description="Feasible designs, best first; when none "
                                                      "is feasible, the closest, feasible false")
    infeasible: list[InfeasibleOut] = Field(..., description="Each family that fails, with its "
                                                             "reason")
    reasons: dict[str, int] = Field(..., description="Number of failing families per reason")
    robustness_studies: Optional[dict[str, dict[str, Any]]] = Field(
        None, description="The best design's strokes (extend, retract) under seal friction "
                          "(half to twice) and supply pressure (5 % of gauge) spread: study "
                          "definitions to POST to /api/studies as they are; null when no "
                          "design is feasible")
    reason_meanings: dict[str, str] = Field(..., description="Each reason in words")
    families: int = Field(..., description="Families tried [-]")
    notes: list[str] = Field(..., description="What the designs' models approximate")
    requirement: dict[str, Any] = Field(..., description="The requirement as checked")
    choices: dict[str, Any] = Field(..., description="The choices as checked")
    units: dict[str, str] = Field(..., description="Unit of each number of the answer")


class SeriesOut(BaseModel):
    label: str = Field(..., description="The series in words")
    source: str = Field(..., description="Where its figures come from")
    members: list[Optional[str]] = Field(..., description="Its members' names (choices name them "
                                                           "as series:member) [-]")
    cushion_capacity: Optional[dict[str, float]] = Field(
        None, description="Cylinders: each member's air cushion's allowable kinetic energy as "
                          "its catalogue gives it (a sizing with a cushion takes it unless "
                          "cushion_capacities names that bore); null = the catalogue gives none [J]")
    bumper_capacity: Optional[dict[str, float]] = Field(
        None, description="Cylinders: each member's rubber bumper's allowable kinetic energy as "
                          "its catalogue gives it (a sizing without a cushion refuses an impact "
                          "above it); null = the catalogue gives none [J]")


class SizingSeriesResponse(BaseModel):
    cylinders: dict[str, SeriesOut] = Field(..., description="Cylinder series by name")
    valves: dict[str, SeriesOut] = Field(..., description="Valve series by name")
    tubes: dict[str, SeriesOut] = Field(..., description="Tube series by name")
