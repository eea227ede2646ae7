"""The sizing search: every family of discrete choices, its continuous settings solved.

A *family* is one cylinder, one valve and (when the requirement has a tube length) one tube
inner diameter. For each family :func:`size`

1. checks the static force at the supply pressure against the load at the mounting angle,
   both ways (no simulation): too weak is the reason ``force``;
2. simulates each direction fully open (a full stroke from rest at one end stop, the valve
   commanded at t = 0, the chamber to be exhausted starting at the supply pressure): a
   full-stroke time above the required one is the reason ``too_slow``; with a cycle time
   instead of the two times, the time to move (the cycle less both dwells) is first shared
   between the strokes in proportion to these fully open times, and the family is too slow
   when their sum exceeds it;
3. with ``choices.meter_out``, solves the sonic conductance of each direction's meter-out
   throttle (the model's ``meter_out_throttle`` on the exhausting port, in series with the
   valve's exhaust edge) for the full-stroke time to equal the required one, by a 1-D root
   (:func:`scipy.optimize.brentq`; the time falls monotonically as the throttle opens,
   towards the valve's own time as the throttle's conductance grows past the valve's). The slowest motion that meets the time is the
   gentlest: its stroke-end speed is the smallest this family reaches;
4. checks the stroke-end speed against ``max_end_speed`` and its kinetic energy against
   ``max_end_energy`` (the cushion's capacity): above is the reason ``end_speed`` or
   ``end_energy``.

The feasible designs are ranked by air per cycle, then size (bore, valve conductance, tube).
Families run in parallel on a thread pool (the compiled integrator releases the GIL), with
``progress(fraction, step)`` called after each family.

The circuit is the model's own (issue 23): the mounting angle is ``jack.mounting_angle``,
the tube the ``tubing`` effect on both ports (its volume and its Fanno-flow resistance), the
flow controls the ``meter_out_throttle`` effect, and the stroke metrics those of
:mod:`pneucore.strokes` (:func:`pneucore.sizing.stroke.direction_metrics`).
"""
from __future__ import annotations

import concurrent.futures as cf
import copy
import math
import os

from scipy.optimize import brentq

from pneucore.physics.jack import annulus_area, net_pressure_force, rod_area
from pneucore.progress import no_progress
from pneucore.simulate import simulate
from pneucore.sizing.requirement import Choices, Requirement
from pneucore.sizing.series import dead_length, resolve_cylinders, resolve_tubes, resolve_valves
from pneucore.sizing.stroke import STROKE_METRIC_UNITS, direction_metrics
from pneucore.spec.effects import EFFECTS, effective_model
from pneucore.spec.model import Model
from pneucore.spec.presets import model_preset
from pneucore.spec.scenario import Scenario
from pneucore.spec.valve_data import C_UNIT
from pneucore.spec.validation import FieldError

#: The model every design is built on (its heat model, friction, gas)
BASE_PRESET = "paper-4way"
#: Each direction's run lasts this many times its required time: the stroke, then the
#: chamber's filling at the end stop (the air a cycle with a dwell draws) [-]
DURATION_FACTOR = 3.0
#: Output samples of a run [-]
RUN_SAMPLES = 1500
#: Longest sample period of a run: the air per stroke is :mod:`pneucore.strokes`' trapezoidal
#: integral of the sampled supply flow, which a chamber's first filling after the command (a
#: few ms) needs samples this close for: on the hand case's retraction (tests/sizing) 5 % too
#: much air at 6 ms, 0.04 % at 2 ms [s]
MAX_SAMPLE_PERIOD = 2e-3
#: Tolerance of the meter-out root, on the logarithm of the exhaust path's conductance
#: (0.1 %; :meth:`_Direction.solve`) [-]
SETTING_XTOL = 1e-3
#: Designs shown, feasible false, when no family is feasible: the closest ones [-]
N_CLOSEST = 3
#: Reasons a family fails, with their meaning
REASONS = {
    "force": "force too low against the load at that angle (static, at the supply pressure)",
    "too_slow": "too slow even fully open",
    "end_speed": "stroke-end speed above the limit at the slowest setting that meets the time",
    "end_energy": "kinetic energy at the end stop above the cushion's capacity at the slowest "
                  "setting that meets the time",
    "simulation": "the simulation of this family failed",
}
DIRECTIONS = ("extend", "retract")
#: The valve edge each direction exhausts through
EXHAUST_EDGE = {"extend": "B-R", "retract": "A-R"}
#: Most families one sizing tries (cylinders x valves x tubes): the shipped series make 390
#: with a tube; beyond this a request is refused before any work [-]
MAX_FAMILIES = 5000


def meter_out_throttles(settings):
    """The ``meter_out_throttle`` effect of a design: one throttle per exhausting port.

    While extending chamber B exhausts (port B, edge B-R), while retracting chamber A (port A,
    edge A-R); each throttle is in series with its exhaust edge (ISO 6358-3, in the model's
    effect), its critical ratio the effect's default.

    Parameters
    ----------
    settings : tuple of float
        Throttle conductances ``(extend, retract)``; 0 = no throttle on that port
        [m^3/(s Pa)]

    Returns
    -------
    params : dict or None
        The effect's parameters (``C_a``, ``b_a``, ``C_b``, ``b_b``); None when neither port
        has a throttle
    """
    c_ext, c_ret = settings
    if c_ext <= 0.0 and c_ret <= 0.0:
        return None
    b = EFFECTS["meter_out_throttle"].param("b_b").default
    return {"C_a": float(c_ret), "b_a": b, "C_b": float(c_ext), "b_b": b}


def _edge(opening, C, b):
    return {"opening": list(opening), "C": list(C), "b": [b, b]}


def build_model(requirement, cylinder, valve, tube=None, settings=(0.0, 0.0), base=None):
    """The model of one design: a single-rod cylinder driven by a 4/2 (5/2) on/off valve.

    The mounting angle is the jack's ``mounting_angle``, the tube the ``tubing`` effect on
    both ports (volume and resistance), the flow controls the ``meter_out_throttle`` effect.

    Parameters
    ----------
    requirement : Requirement
        The required motion (stroke, mass, load, angle, supply, tube length)
    cylinder : dict
        ``bore`` [m] and ``rod`` [m] (the rod on the chamber-B side)
    valve : dict
        ``C``, ``b`` of the supply edges and ``C_exhaust``, ``b_exhaust`` of the exhaust
        edges [m^3/(s Pa)], [-]
    tube : dict or None
        ``inner_diameter`` [m] of the tube on each port (its length is the requirement's)
    settings : tuple of float
        Meter-out throttle conductances ``(extend, retract)``: on port B (exhausting while
        extending) and port A (exhausting while retracting); 0 = none [m^3/(s Pa)]
    base : dict or None
        Model to build on (heat, friction, gas); None = the ``paper-4way`` preset

    Returns
    -------
    model : dict
        Plain JSON of the model (:meth:`pneucore.spec.model.Model.from_dict` accepts it)
    """
    d = copy.deepcopy(base) if base is not None else model_preset(BASE_PRESET)
    ref_bore = d["jack"]["bore"]
    bore, rod = cylinder["bore"], cylinder["rod"]
    L0 = dead_length()
    d["jack"] = {"bore": bore, "rod_a": 0.0, "rod_b": rod, "stroke": requirement.stroke,
                 "dead_volume_a": annulus_area(bore, 0.0) * L0,
                 "dead_volume_b": annulus_area(bore, rod) * L0,
                 "moving_mass": requirement.moving_mass, "load_force": requirement.load_force,
                 "mounting_angle": requirement.angle, "wall_area_a": None, "wall_area_b": None}
    # seal friction scales with the seal's perimeter: the base cylinder's, times bore ratio
    ratio = bore / ref_bore
    for side in ("extend", "retract"):
        fs = d["friction"].get(side) or d["friction"]["extend"]
        d["friction"][side] = {k: v * ratio for k, v in fs.items()}
    # on/off valve: u = +1 pressurises A and exhausts B, u = -1 the reverse (paper's 4/2 axis)
    C_x, b_x = valve["C_exhaust"], valve["b_exhaust"]
    d["valve"] = {"kind": "4/2", "b_chamber_pressure": None,
                  "flow_law": d["valve"].get("flow_law", "iso6358"),
                  "ports": {"P-A": _edge((0.0, 1.0), (0.0, valve["C"]), valve["b"]),
                            "B-R": _edge((0.0, 1.0), (0.0, C_x), b_x),
                            "P-B": _edge((-1.0, 0.0), (valve["C"], 0.0), valve["b"]),
                            "A-R": _edge((-1.0, 0.0), (C_x, 0.0), b_x)}}
    d["supply"] = {**d.get("supply", {}), "pressure": requirement.supply_pressure}
    d["ambient"] = {**d.get("ambient", {}), "pressure": requirement.ambient_pressure}
    # the throttle first: screwed into the cylinder port, upstream of the tube on the exhaust
    d["effects"] = {}
    throttles = meter_out_throttles(settings)
    if throttles is not None:
        d["effects"]["meter_out_throttle"] = throttles
    if tube is not None and requirement.tube_length is not None:
        L, di = requirement.tube_length, tube["inner_diameter"]
        d["effects"]["tubing"] = {"length_a": L, "diameter_a": di, "length_b": L, "diameter_b": di}
    s_ext, s_ret = settings
    d["name"] = f"sizing: {cylinder['name']} + {valve['name']}" + \
        (f" + {tube['name']}" if tube is not None and requirement.tube_length else "")
    d["description"] = (f"Designed by pneucore.sizing: bore {bore * 1e3:g} mm, rod {rod * 1e3:g} mm, "
                        f"stroke {requirement.stroke * 1e3:g} mm, valve C {valve['C']:.3g} "
                        f"m^3/(s Pa), meter-out throttle C {s_ext:.3g} (extend, port B) / "
                        f"{s_ret:.3g} (retract, port A) m^3/(s Pa), 0 = none")
    d["notes"] = " ".join(model_notes(requirement, tube))
    return d


def model_notes(requirement, tube=None):
    """What the designs' models approximate, in words (the answer's ``notes``).

    Parameters
    ----------
    requirement : Requirement
        The requirement
    tube : dict or None
        The tube of a design, if any

    Returns
    -------
    notes : list of str
    """
    notes = [
        f"Mounting angle {requirement.angle:g} deg: the model's jack.mounting_angle (the weight "
        "along the rod, m g sin(angle), adds to the load: at 90 deg, rod up, the extension lifts "
        "the load).",
        "Meter-out flow control: the model's meter_out_throttle effect, a throttle on the "
        "exhausting port in series with the valve's exhaust edge (ISO 6358-3); its conductance "
        "is solved for the required time, its critical ratio the effect's default.",
        f"Dead volume of each chamber: {dead_length() * 1e3:g} mm of bore (the paper's 32 mm jack, "
        "5 cm^3; not in the standards). Seal friction: the base model's, scaled with the bore.",
        "Valve switching time is not modelled: the valve opens fully at the command.",
    ]
    if requirement.cycle_time is not None:
        notes.append(f"Cycle time {requirement.cycle_time:g} s with a dwell of "
                     f"{requirement.dwell:g} s at each end: each family's {requirement.motion_time:g} s "
                     "to move is shared between its strokes in proportion to their fully open "
                     "times (both slowed by the same factor); each design's required_times "
                     "gives its share.")
    if requirement.tube_length is not None:
        notes.append(f"Tube of {requirement.tube_length:g} m on each port: the model's tubing "
                     "effect, its volume pi d^2 L / 4 added to each chamber's dead volume and its "
                     "resistance (Fanno flow, friction at the supply pressure) in series with the "
                     "port's valve edges (ISO 6358-3); lumped, no transport delay.")
    return notes


def _force_reason(requirement, cylinder, model):
    """``(direction, detail)`` when the static force cannot move the load, else None."""
    j, f = model.jack, model.friction
    p_s, p_0 = requirement.supply_pressure, requirement.ambient_pressure
    load = j.total_load
    dp = p_s - p_0
    A_a, A_b, Ar = j.area_a, j.area_b, rod_area(cylinder["rod"])
    fc_ext = f.extend.fc0 + f.extend.fc_a * dp
    fc_ret = f.retract.fc0 + f.retract.fc_b * dp
    # the law's Python body (.py_func): the same source as the compiled core's, without a
    # compile of its own at the first call of a process (about 2 s)
    force = net_pressure_force.py_func
    push = force(p_s, p_0, p_0, A_a, A_b, 0.0, Ar, load)
    pull = -force(p_0, p_s, p_0, A_a, A_b, 0.0, Ar, load)
    if push - fc_ext <= 0.0:
        return "extend", (f"extension: {push + load:.4g} N of pressure force at "
                          f"{p_s / 1e5:.4g} bar abs against {load:.4g} N of load (gravity "
                          f"included) and {fc_ext:.3g} N of seal friction")
    if pull - fc_ret <= 0.0:
        return "retract", (f"retraction: {pull - load:.4g} N of pressure force at "
                           f"{p_s / 1e5:.4g} bar abs against {-load:.4g} N of load pulling out "
                           f"(gravity included) and {fc_ret:.3g} N of seal friction")
    return None


class _Direction:
    """One direction of one family: the model, its scenario, runs cached by throttle."""

    #: the port of this direction's meter-out throttle (the exhausting chamber's)
    PORT = {"extend": "C_b", "retract": "C_a"}

    def __init__(self, model, requirement, direction):
        self.model = model
        self.direction = direction
        self.t_req = requirement.time_bound(direction)
        self.scenario = Scenario.from_dict(_stroke_scenario(requirement, direction), model)
        self.runs = {}

    def run(self, C):
        """Stroke metrics with a throttle of conductance ``C`` [m^3/(s Pa)] (0 = none), cached;
        the full-stroke time is None when the end stop is not reached."""
        if C not in self.runs:
            effects = {k: v for k, v in self.model.effects.items() if k != "meter_out_throttle"}
            throttles = meter_out_throttles((C, 0.0) if self.direction == "extend" else (0.0, C))
            self.model.effects = ({"meter_out_throttle": throttles} if throttles else {}) | effects
            res = simulate(self.model, self.scenario, raise_on_error=False)
            m = direction_metrics(res, self.direction)
            if res.status != 0:
                m["full_stroke_time"] = None
                m["failure"] = res.message
            self.runs[C] = m
        return self.runs[C]

    def time(self, C):
        t = self.run(C)["full_stroke_time"]
        return math.inf if t is None else t

    def solve(self, C_min, C_edge):
        """The throttle whose full-stroke time is the required one [m^3/(s Pa)]: ``C_min`` if
        even that is fast enough, 0 (none) when only the valve alone meets the time.

        The root is sought on ``y = ln(C_path / C_edge)`` in ``[ln(C_path(C_min) / C_edge),
        0]``, ``C_path`` the conductance of throttle and edge in series by the effective
        areas' rule ``1 / C_path^2 = 1 / C^2 + 1 / C_edge^2`` (JIS B 8390): a change of
        variable only (the runs use the model's ISO 6358-3 chain), which makes the time
        nearly proportional to ``exp(-y)``, so the root takes few runs; ``y = 0`` is no
        throttle (the fully open run).
        """
        if self.time(C_min) <= self.t_req:
            return C_min
        cap = DURATION_FACTOR * self.t_req

        def throttle(y):
            return 0.0 if y >= 0.0 else C_edge / math.sqrt(math.expm1(-2.0 * y))

        def g(y):
            return math.log(min(self.time(throttle(y)), cap) / self.t_req)
        y_min = -0.5 * math.log1p((C_edge / C_min) ** 2)
        C = throttle(brentq(g, y_min, 0.0, xtol=SETTING_XTOL))
        if self.time(C) > self.t_req:
            # the root's bracket end on the fast side meets the time for sure
            C = min((k for k in self.runs if k > 0.0 and self.time(k) <= self.t_req),
                    default=0.0)
        return C


def _stroke_scenario(requirement, direction):
    """The scenario of one full stroke: at rest at one end stop, the chamber to be exhausted
    at the supply pressure (where the previous stroke left it), the valve switched at the
    first sample after t = 0 (the ``command`` event :mod:`pneucore.strokes` times from)."""
    t_req = requirement.time_bound(direction)
    period = min(DURATION_FACTOR * t_req / RUN_SAMPLES, MAX_SAMPLE_PERIOD)
    p_s, p_0 = requirement.supply_pressure, requirement.ambient_pressure
    ext = direction == "extend"
    return {"duration": period + DURATION_FACTOR * t_req, "sample_period": period,
            "command": [[0.0, 0.0], [period, 1.0 if ext else -1.0]],
            "command_interpolation": "hold", "locked": False,
            "x0": 0.0 if ext else requirement.stroke,
            "initial": {"p_a": p_0 if ext else p_s, "p_b": p_s if ext else p_0}}


#: Spread of the robustness studies: seal friction from half to twice the design's (it
#: drifts with service life: the paper's closing warning), supply pressure normal with this
#: standard deviation as a fraction of the gauge pressure, truncated at 3 of them [-]
FRICTION_SPREAD = (0.5, 2.0)
SUPPLY_STD = 0.05
#: Runs of each robustness study [-]
ROBUSTNESS_SAMPLES = 200


def robustness_studies(design, requirement, samples=ROBUSTNESS_SAMPLES):
    """Study definitions of a design's strokes under friction and supply variation.

    One study per direction, ready for ``POST /api/studies`` (or
    :func:`pneucore.study.run_study`) as they are: the design's model, the full stroke of
    the sizing (from rest at the end stop), the seal friction of that direction drawn
    uniformly from :data:`FRICTION_SPREAD` times the design's, the supply pressure normal
    (:data:`SUPPLY_STD` of the gauge pressure). Their ``t95`` (time to 95 % of the travel)
    spread is the stroke time's.

    Parameters
    ----------
    design : dict
        A design of :func:`size` (its ``model``)
    requirement : Requirement
        The requirement it was sized for
    samples : int
        Runs of each study [-]

    Returns
    -------
    studies : dict
        ``{"extend": study, "retract": study}`` (plain JSON study definitions)
    """
    model = design["model"]
    p_s, p_0 = requirement.supply_pressure, requirement.ambient_pressure
    std = SUPPLY_STD * (p_s - p_0)
    out = {}
    for k in DIRECTIONS:
        ext = k == "extend"
        duration = DURATION_FACTOR * requirement.time_bound(k)
        fs = model["friction"][k]
        lo, hi = FRICTION_SPREAD
        params = {f"friction.{k}.{c}": {"distribution": "uniform", "min": lo * fs[c],
                                        "max": hi * fs[c]}
                  for c in ("fc0", "kv0") if fs[c] > 0.0}
        params["supply.pressure"] = {"distribution": "normal", "mean": p_s, "std": std,
                                     "min": max(p_s - 3 * std, p_0 * 1.01), "max": p_s + 3 * std}
        out[k] = {"name": f"{model.get('name', 'design')}: {k} under friction and supply spread",
                  "model": model,
                  "scenario": {"duration": duration, "sample_period": duration / RUN_SAMPLES,
                               "command": [[0.0, 1.0 if ext else -1.0]],
                               "command_interpolation": "hold", "locked": False,
                               "x0": 0.0 if ext else requirement.stroke,
                               "initial": {"p_a": p_0 if ext else p_s,
                                           "p_b": p_s if ext else p_0}},
                  "parameters": params, "samples": int(samples), "seed": 1,
                  "metrics": ["t95", "x_final", "overshoot", "air_consumption"]}
    return out


def _family_key(cylinder, valve, tube):
    return {"cylinder": cylinder, "valve": valve, "tube": tube}


def evaluate_family(requirement, choices, cylinder, valve, tube=None, base=None):
    """Size one family: force check, fully-open runs, meter-out roots, end-speed check.

    Parameters
    ----------
    requirement : Requirement
        The required motion
    choices : Choices
        ``meter_out`` and ``min_meter_out`` are read
    cylinder, valve, tube : dict
        The family's members (:mod:`pneucore.sizing.series` records); tube may be None
    base : dict or None
        Model to build on; None = the ``paper-4way`` preset

    Returns
    -------
    outcome : dict
        ``feasible``; a feasible family's ``design`` (model, settings, metrics, air per
        cycle); an infeasible one's ``reason`` (a key of :data:`REASONS`), ``direction`` and
        ``detail``, and ``design`` fully open where its runs exist
    """
    try:
        return _evaluate(requirement, choices, cylinder, valve, tube, base)
    except (ArithmeticError, ValueError) as exc:
        # a numerical failure of one family (a root without a bracket, an overflow) is that
        # family's outcome, not the search's
        return {**_family_key(cylinder, valve, tube), "feasible": False, "reason": "simulation",
                "direction": None, "detail": f"{type(exc).__name__}: {exc}"}


def _evaluate(requirement, choices, cylinder, valve, tube, base):
    family = _family_key(cylinder, valve, tube)
    d = build_model(requirement, cylinder, valve, tube, base=base)
    try:
        model = Model.from_dict(d)
    except FieldError as exc:
        return {**family, "feasible": False, "reason": "simulation", "direction": None,
                "detail": f"the model of this family is refused: {exc}"}
    weak = _force_reason(requirement, cylinder, model)
    if weak is not None:
        return {**family, "feasible": False, "reason": "force", "direction": weak[0],
                "detail": weak[1]}
    try:
        dirs = {k: _Direction(model.copy(), requirement, k) for k in DIRECTIONS}
        full = {k: dr.run(0.0) for k, dr in dirs.items()}
        for k, m in full.items():
            if "failure" in m:
                return {**family, "feasible": False, "reason": "simulation", "direction": k,
                        "detail": f"{k}: {m['failure']}"}
        if requirement.cycle_time is not None:
            cycle = _share_cycle(requirement, dirs, family, cylinder, valve, tube, full, base)
            if cycle is not None:
                return cycle
        slow = [k for k, dr in dirs.items() if dr.time(0.0) > dr.t_req]
        if slow:
            k = max(slow, key=lambda k: dirs[k].time(0.0) / dirs[k].t_req)
            t = full[k]["full_stroke_time"]
            took = f"{t:.4g} s" if t is not None else \
                f"not at the end stop after {DURATION_FACTOR * dirs[k].t_req:.4g} s"
            design = _design(requirement, cylinder, valve, tube, {k: 0.0 for k in DIRECTIONS},
                             full, base)
            return {**family, "feasible": False, "reason": "too_slow", "direction": k,
                    "detail": f"{k}: full-stroke time fully open {took}, required "
                              f"{dirs[k].t_req:.4g} s",
                    "shortfall": dirs[k].time(0.0) / dirs[k].t_req,
                    "design": {**design, "feasible": False}}
        C_min = choices.min_meter_out * valve["C_exhaust"]
        settings = {k: dr.solve(C_min, valve["C_exhaust"]) if choices.meter_out else 0.0
                    for k, dr in dirs.items()}
        metrics = {k: dirs[k].run(settings[k]) for k in DIRECTIONS}
    except FieldError as exc:
        return {**family, "feasible": False, "reason": "simulation", "direction": None,
                "detail": str(exc)}
    design = _design(requirement, cylinder, valve, tube, settings, metrics, base,
                     {k: dirs[k].t_req for k in DIRECTIONS})
    checks = (("end_speed", "stroke-end speed", requirement.max_end_speed, "m/s"),
              ("end_energy", "kinetic energy at the end stop", requirement.max_end_energy, "J"))
    for reason, what, limit, unit in checks:
        if limit is None:
            continue
        for k in DIRECTIONS:
            value = metrics[k][reason]
            if value is not None and value > limit:
                return {**family, "feasible": False, "reason": reason, "direction": k,
                        "detail": f"{k}: {what} {value:.3g} {unit} at the slowest setting that "
                                  f"meets {dirs[k].t_req:.4g} s (meter-out throttle C "
                                  f"{settings[k]:.3g} m^3/(s Pa), 0 = none), "
                                  f"limit {limit:.3g} {unit}",
                        "shortfall": value / limit, "design": {**design, "feasible": False}}
    return {**family, "feasible": True, "design": design}


def _share_cycle(requirement, dirs, family, cylinder, valve, tube, full, base):
    """With a cycle time: each direction's required time, the time to move shared in
    proportion to the fully open times (both strokes slowed by the same factor, so neither
    is left at full speed while the other crawls); the ``too_slow`` outcome when even fully
    open the two strokes take longer than the time to move, else None (``dirs`` updated)."""
    t0 = {k: dirs[k].time(0.0) for k in DIRECTIONS}
    total, budget = t0["extend"] + t0["retract"], requirement.motion_time
    if total <= budget:
        for k in DIRECTIONS:
            dirs[k].t_req = budget * t0[k] / total
        return None
    k = max(DIRECTIONS, key=lambda k: t0[k])
    took = " + ".join(f"{n} {t0[n]:.4g} s" if math.isfinite(t0[n]) else
                      f"{n} not at the end stop after {DURATION_FACTOR * budget:.4g} s"
                      for n in DIRECTIONS)
    design = _design(requirement, cylinder, valve, tube, {n: 0.0 for n in DIRECTIONS}, full, base)
    return {**family, "feasible": False, "reason": "too_slow", "direction": k,
            "detail": f"cycle: fully open {took}, more than the {budget:.4g} s to move (cycle "
                      f"{requirement.cycle_time:.4g} s less two dwells of {requirement.dwell:.4g} s)",
            "shortfall": total / budget, "design": {**design, "feasible": False}}


def _design(requirement, cylinder, valve, tube, settings, metrics, base, times=None):
    model = build_model(requirement, cylinder, valve, tube,
                        (settings["extend"], settings["retract"]), base=base)
    air = metrics["extend"]["air"] + metrics["retract"]["air"]
    # the exhaust path each way as the model sees it: throttle, tube and valve edge in series
    ports = effective_model(Model.from_dict(model)).valve.ports
    return {
        "cylinder": cylinder, "valve": valve,
        "tube": tube if requirement.tube_length is not None else None,
        "settings": {f"{k}_meter_out_C": settings[k] for k in DIRECTIONS}
        | {f"{k}_exhaust_C": max(ports[EXHAUST_EDGE[k]].C) for k in DIRECTIONS},
        "model": model,
        "metrics": {k: {n: metrics[k][n] for n in STROKE_METRIC_UNITS} for k in DIRECTIONS}
        | {"units": dict(STROKE_METRIC_UNITS)},
        "air_per_cycle": air,
        # the full-stroke time each direction was sized for (with a cycle time, its share)
        "required_times": {k: requirement.time_bound(k) if times is None else times[k]
                           for k in DIRECTIONS},
        "feasible": True,
    }


#: Significant digits to which air per cycle is compared when ranking: closer than that, the
#: difference is the solver's tolerance (rtol 1e-5 over a run) rather than the design's, and
#: the smaller design ranks first [-]
AIR_DIGITS = 3


def _size_key(design):
    tube = design["tube"]["inner_diameter"] if design["tube"] else 0.0
    air = float(f"{design['air_per_cycle']:.{AIR_DIGITS}g}")
    return (air, design["cylinder"]["bore"], design["valve"]["C"], tube)


def families(requirement, choices):
    """Every family of the choices: ``(cylinder, valve, tube)`` (tube None without a tube).

    Parameters
    ----------
    requirement : Requirement
        The requirement (its tube length decides whether tubes vary)
    choices : Choices
        The discrete choices

    Returns
    -------
    families : list of tuple
    """
    cyl = resolve_cylinders(choices.bore)
    val = resolve_valves(choices.valve)
    tubes = resolve_tubes(choices.tube_inner_diameter) if requirement.tube_length is not None \
        else [None]
    n = len(cyl) * len(val) * len(tubes)
    if n > MAX_FAMILIES:
        raise FieldError("choices", f"{len(cyl)} cylinders x {len(val)} valves x {len(tubes)} "
                                    f"tubes = {n} families, more than {MAX_FAMILIES}: choose fewer")
    return [(c, v, t) for c in cyl for v in val for t in tubes]


def default_workers():
    """Threads of a sizing by default: the CPUs this process may use [-]."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def check(requirement, choices=None, max_duration=None):
    """Everything a sizing request can get wrong, checked before any work.

    Parameters
    ----------
    requirement : Requirement or dict
        The required motion
    choices : Choices or dict or None
        What may vary
    max_duration : float or None
        Longest simulated time of one run allowed [s]; each direction's run lasts
        :data:`DURATION_FACTOR` times its required time

    Returns
    -------
    checked : tuple
        ``(requirement, choices, families)``
    """
    req = Requirement.from_dict(requirement)
    ch = Choices.from_dict(choices)
    if max_duration is not None:
        for k in DIRECTIONS:
            key = f"{k}_time" if req.cycle_time is None else "cycle_time"
            if DURATION_FACTOR * req.time_bound(k) > max_duration:
                raise FieldError(f"requirement.{key}", (
                    f"{getattr(req, key):g} s: each direction is simulated for {DURATION_FACTOR:g} "
                    f"times the most it may take ({req.time_bound(k):g} s), more than the "
                    f"{max_duration:g} s a run may last here (GET /api/limits: max_duration) "
                    f"(unit: s)"))
    return req, ch, families(req, ch)


def size(requirement, choices=None, workers=None, progress=None, base=None, checked=None):
    """Size a drive: the designs that meet the requirement, best first, and why others fail.

    Parameters
    ----------
    requirement : Requirement or dict
        The required motion (:class:`~pneucore.sizing.requirement.Requirement`)
    choices : Choices or dict or None
        What may vary; None = every shipped series, meter-out solved
    workers : int or None
        Threads evaluating families at once; None = the CPUs available [-]
    progress : callable or None
        ``progress(fraction, step)`` after each family; it may raise to stop the search
    base : dict or None
        Model the designs are built on (heat, friction, gas); None = the ``paper-4way``
        preset
    checked : tuple or None
        What :func:`check` returned for these arguments (not checked again)

    Returns
    -------
    answer : dict
        ``designs`` (feasible, ranked by air per cycle then size; when none is feasible, the
        closest families fully open, ``feasible`` false), ``infeasible`` (each failing
        family with its ``reason`` and ``detail``), ``reasons`` (counts),
        ``robustness_studies`` (the best design's strokes under friction and supply spread,
        ready for ``POST /api/studies``; null without a feasible design), ``notes``,
        ``families`` (count), ``requirement``, ``choices``, ``units``

    Examples
    --------
    >>> ans = size({"stroke": 0.1, "moving_mass": 2.0, "load_force": 20.0, "angle": 0.0,
    ...             "supply_pressure": 7e5, "extend_time": 0.5, "retract_time": 0.5},
    ...            {"bore": ["iso15552:32"], "valve": ["ckd-4ga:M4GA1"]}, workers=1)
    >>> ans["designs"][0]["cylinder"]["name"], ans["designs"][0]["feasible"]
    ('iso15552:32', True)
    """
    req, ch, fams = checked if checked is not None else check(requirement, choices)
    progress = progress or no_progress
    workers = max(1, int(workers or default_workers()))
    outcomes = [None] * len(fams)
    progress(0.0, f"sizing: {len(fams)} families")
    # the first family in this thread: the compiled core is loaded (or compiled) once, by one
    # thread, before the worker threads call it
    serial = len(fams) if workers == 1 else min(1, len(fams))
    for i, (c, v, t) in enumerate(fams[:serial]):
        outcomes[i] = evaluate_family(req, ch, c, v, t, base)
        progress((i + 1) / len(fams), f"family {i + 1} of {len(fams)}")
    if serial < len(fams):
        with cf.ThreadPoolExecutor(workers, thread_name_prefix="pneucore-sizing") as pool:
            futures = {pool.submit(evaluate_family, req, ch, c, v, t, base): i
                       for i, (c, v, t) in enumerate(fams) if i >= serial}
            try:
                for n, f in enumerate(cf.as_completed(futures), serial + 1):
                    outcomes[futures[f]] = f.result()
                    progress(n / len(fams), f"family {n} of {len(fams)}")
            except BaseException:
                for f in futures:
                    f.cancel()
                raise
    return _answer(req, ch, outcomes)


def _answer(req, ch, outcomes):
    designs = sorted((o["design"] for o in outcomes if o["feasible"]), key=_size_key)
    infeasible = []
    for o in outcomes:
        if o["feasible"]:
            continue
        infeasible.append({"cylinder": o["cylinder"], "valve": o["valve"],
                           "tube": o["tube"] if req.tube_length is not None else None,
                           "reason": o["reason"], "direction": o["direction"],
                           "detail": o["detail"]})
    if not designs:
        close = sorted((o for o in outcomes if not o["feasible"] and "design" in o),
                       key=lambda o: o["shortfall"])
        designs = [o["design"] for o in close[:N_CLOSEST]]
    counts = {}
    for o in infeasible:
        counts[o["reason"]] = counts.get(o["reason"], 0) + 1
    for rank, dsg in enumerate(designs, 1):
        dsg["rank"] = rank
    summary = (f"{sum(o['feasible'] for o in outcomes)} of {len(outcomes)} families meet the "
               "requirement")
    if not any(o["feasible"] for o in outcomes):
        summary = "no family meets the requirement: " + "; ".join(
            f"{n} {REASONS[r]}" for r, n in sorted(counts.items()))
    robust = robustness_studies(designs[0], req) if designs and designs[0]["feasible"] else None
    return {"summary": summary, "designs": designs, "infeasible": infeasible, "reasons": counts,
            "robustness_studies": robust,
            "reason_meanings": dict(REASONS), "families": len(outcomes),
            "notes": model_notes(req) + ([
                "tube_inner_diameter choices ignored: the requirement has no tube_length."]
                if ch.tube_inner_diameter and req.tube_length is None else []),
            "requirement": req.to_dict(), "choices": ch.to_dict(),
            "units": {"air_per_cycle": "NL", **{f"metrics.*.{k}": u
                                                  for k, u in STROKE_METRIC_UNITS.items()},
                      "settings.*_meter_out_C": C_UNIT, "settings.*_exhaust_C": C_UNIT}}
